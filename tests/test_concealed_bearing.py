"""Bearing-side concealed cases (issue 14, benches.concealed.BEARING_CASES): the committed
ones with the further measurements regenerate, a case without them is the same data less
the extras, and the extras carry the concealed effect where the six spectra cannot."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from benches.concealed import BEARING_CASES, COMMITTED_BEARING, BenchConfig, generate
from benches.drive_extra import shaft_frame_impedance
from benches.truth import lubricant_at_speed
from vfmodel.core.io_dataset import read_dataset
from vfmodel.greybox.assembly import TOPOLOGY_PORTS, default_params
from vfmodel.greybox.params import ParamSet

ROOT = Path(__file__).resolve().parents[1]
DIR = ROOT / "data" / "concealed"
CASES: dict[str, dict[str, Any]] = json.loads((DIR / "cases.json").read_text())
BY_NAME = {c.name: c for c in BEARING_CASES}
COMMITTED = list(COMMITTED_BEARING)
SIG = BenchConfig().z_noise / np.sqrt(2)          # noise of each component of log Z


def test_bearing_cases_listed_and_readable() -> None:
    assert {c.effect for c in BEARING_CASES} == {"lubricant_two_layer", "metallic_contact",
                                                  "lubricant_dielectric_loss",
                                                  "hertzian_edge_capacitance", None}
    assert set(COMMITTED) <= set(BY_NAME) and all(BY_NAME[n].extra for n in COMMITTED)
    for name in COMMITTED:
        c = BY_NAME[name]
        e = CASES[name]
        assert e["without"] == list(c.without) and e["effect"] == c.effect
        assert e["truth_rungs"] == 5 and e["truth_sections"] == 3
        ds = read_dataset(DIR / name)
        assert "Shaft-Frame" in ds.further_impedance
        assert sorted(s.speed_rpm for s in ds.impedance_at_speed) == [100.0, 300.0]
        for r in ds.recordings:
            assert set(r.channels) == {"u_U", "u_V", "u_W", "u_B", "u_B_DE", "i_CM"}
        size = sum(p.stat().st_size for p in (DIR / name).rglob("*") if p.is_file())
        assert size <= 1.8e6, f"{name}: {size / 1e6:.2f} MB"


def test_twin_without_extras_is_the_same_data() -> None:
    """``pmsm_two_layer`` = ``pmsm_two_layer_x`` less the extras (same truth and noise)."""
    a = generate(BY_NAME["pmsm_two_layer"])
    b = generate(BY_NAME["pmsm_two_layer_x"])
    assert not a.shaft_frame and not a.extra_records
    assert a.params.values == b.params.values
    for t in a.spectra:
        np.testing.assert_array_equal(a.spectra[t], b.spectra[t])
    for s in a.recordings:
        np.testing.assert_array_equal(a.recordings[s], b.recordings[s])
    assert sorted(b.shaft_frame) == [0.0, 100.0, 300.0]
    assert all(y.shape == (2, a.recordings[s].shape[1]) for s, y in b.extra_records.items())


def test_committed_case_regenerates() -> None:
    name = "pmsm_two_layer_x"
    d = generate(BY_NAME[name], seed=int(CASES[name]["seed"]))
    ds = read_dataset(DIR / name)
    # rounding of the network solves only (see test_concealed_data)
    np.testing.assert_allclose(ds.further_impedance["Shaft-Frame"].values[:, 0, 0],
                               d.shaft_frame[0.0], rtol=1e-9, atol=0)
    for s in ds.impedance_at_speed:
        np.testing.assert_allclose(s.data.values[:, 0, 0], d.shaft_frame[s.speed_rpm],
                                   rtol=1e-9, atol=0)
    for r in ds.recordings:
        y = d.extra_records[float(r.speed_rpm or 0.0)]
        got = r.data[[r.channels.index("u_B_DE"), r.channels.index("i_CM")]]
        tol = 1e-6 * np.max(np.abs(y), axis=1, keepdims=True)
        assert np.all(np.abs(got.astype(np.float32) - y) <= tol)


def _shaft_frame(p: ParamSet, effects: frozenset[str], rpm: float,
                 cfg: BenchConfig) -> np.ndarray:
    ps, st = lubricant_at_speed(p, rpm)
    return shaft_frame_impedance(cfg.spec(effects).build(ps, st), cfg.freq_hz)


@pytest.mark.parametrize("name", ["pmsm_two_layer_x", "pmsm_contact_x"])
def test_extras_carry_the_effect(name: str) -> None:
    """At the truth values, the Shaft-Frame spectrum with and without the concealed effect
    differs by many noise sigma (two-layer film: at speed; metallic contact: at
    standstill)."""
    case = BY_NAME[name]
    assert case.effect is not None
    cfg = case.config(BenchConfig())
    tj = json.loads((DIR / name / "truth.json").read_text())
    p = default_params().with_values(tj["truth_params"])
    rpm = 0.0 if case.effect == "metallic_contact" else 100.0
    z1 = _shaft_frame(p, case.truth_effects, rpm, cfg)
    z0 = _shaft_frame(p, case.truth_effects - {case.effect}, rpm, cfg)
    dev = float(np.max(np.abs(np.log(z1 / z0))))
    assert dev >= 10 * SIG, f"{name}: {dev / SIG:.1f} sigma"
    if case.effect == "lubricant_two_layer":
        # the film is shorted by the metallic contact at standstill: the six spectra do
        # not see it at all
        ps, st = lubricant_at_speed(p, 0.0)
        pairs = [TOPOLOGY_PORTS[t] for t in TOPOLOGY_PORTS]
        za = cfg.spec(case.truth_effects).build(ps, st).mna.response(cfg.freq_hz[::20],
                                                                     pairs, pairs)
        zb = cfg.spec(case.truth_effects - {case.effect}).build(ps, st).mna.response(
            cfg.freq_hz[::20], pairs, pairs)
        assert float(np.max(np.abs(np.log(np.diagonal(za, axis1=1, axis2=2)
                                          / np.diagonal(zb, axis1=1, axis2=2))))) < 0.1 * SIG


def test_wide_case_is_the_extras_case_with_the_shaft_frame_to_100_mhz() -> None:
    """``pmsm_edge_w``: the six spectra and the records of ``pmsm_edge`` (same truth and
    noise); its Shaft-Frame spectra continue the spectra's grid (50 points per decade) to
    100 MHz and are the truth's within the bench noise (6 sigma of 0.5 %)."""
    a = generate(BY_NAME["pmsm_edge"])
    w = generate(BY_NAME["pmsm_edge_w"])
    for t in a.spectra:
        np.testing.assert_array_equal(a.spectra[t], w.spectra[t])
    for s in a.recordings:
        np.testing.assert_array_equal(a.recordings[s], w.recordings[s])
    f = w.config.shaft_frame_freq_hz
    assert f.size == 251 and f[-1] == 1e8
    np.testing.assert_allclose(f[:201], a.config.freq_hz, rtol=1e-12)
    assert sorted(w.shaft_frame) == [0.0, 100.0, 300.0]
    case = BY_NAME["pmsm_edge_w"]
    cfg = case.config(BenchConfig())
    for rpm, z in w.shaft_frame.items():
        ps, st = lubricant_at_speed(w.params, rpm)
        z0 = shaft_frame_impedance(cfg.spec(case.truth_effects).build(ps, st), f)
        assert float(np.max(np.abs(z / z0 - 1))) < 6 * BenchConfig().z_noise
