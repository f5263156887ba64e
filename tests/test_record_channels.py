"""The further recording channels ``u_B_DE`` and ``i_CM`` as detective channels
(:mod:`vfmodel.detective.record_channels`, CONTRACT section 2a, issue 14).

References: records made by the project's bench code (:func:`vfmodel.greybox.drive.
steady_state` and :func:`benches.drive_extra.extra_steady_state`: inverter, cable and the
grey-box machine, each channel through the scope's probe), i.e. computed from the inverter
sources through the drive circuit, not from the measured terminal voltages as the channel's
model is; central differences of the residual with direct (sparse LU) solves.
"""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from benches.drive_extra import extra_steady_state
from tests.conftest import REPO
from vfmodel.circuit import transfer
from vfmodel.core.recording import Recording
from vfmodel.detective import pmsm
from vfmodel.detective.pmsm import PmsmFamily, _bearing_term, pmsm_family
from vfmodel.detective.record_channels import RecordChannelTerm, record_terms
from vfmodel.greybox.assembly import default_params
from vfmodel.greybox.drive import CableSpec, InverterSpec, ScopeSpec, drive_circuit, steady_state
from vfmodel.greybox.effects import PAPER_EFFECTS
from vfmodel.greybox.identify import machine_names
from vfmodel.greybox.network import NetSpec
from vfmodel.greybox.objective import prepare_recording

RPM = 300.0
CHANNELS = ("u_U", "u_V", "u_W", "u_B", "u_B_DE", "i_CM")
EFFECTS = frozenset(PAPER_EFFECTS)
SPEC = NetSpec(EFFECTS, 3, 2)
# the two shaft halves differ (default: equal, and then u_B_DE = u_B to rounding)
P = default_params().with_values({"shaft.L_2": 3e-7})


def _clean() -> np.ndarray:
    """Noise-free bench record (6, n) at 300 rpm: 4 PWM periods at 50 MHz (the concealed
    cases' acquisition)."""
    net = SPEC.build(P, "rotating")
    inv, cable, scope = InverterSpec(), CableSpec(), ScopeSpec(fs_hz=50e6, n_periods=4)
    mna = drive_circuit(net, cable).mna
    return np.vstack([steady_state(net, inv, cable, scope, RPM, mna=mna),
                      extra_steady_state(net, inv, cable, scope, RPM, mna=mna)])


def _family(data: np.ndarray) -> tuple[PmsmFamily, list[RecordChannelTerm]]:
    rec = Recording(50e6, data, CHANNELS, RPM)
    prep = prepare_recording(rec)
    fam = PmsmFamily("t", EFFECTS, 3, 2, (), {}, (), np.zeros(0), (prep,), P)
    return fam, record_terms([rec], [prep], _bearing_term)


@pytest.fixture(scope="module")
def clean() -> np.ndarray:
    return _clean()


def test_channel_model_equals_the_bench_record(clean: np.ndarray) -> None:
    """Noise-free: the channel's model (network transfer from the measured terminal voltages
    to SD, resp. minus the sum of the source currents, in periodic steady state) equals the
    bench's own waveform (computed from the inverter through cable and probe) to 1e-4 RMS
    (measured 3e-8 / 4e-9 for u_B_DE / i_CM), and its H1 through the same estimator equals
    the measured H1 to 1e-6 (measured 1.1e-8 / 8e-9). A wrong sign of i_CM or a wrong node
    is off by order 1."""
    fam, rts = _family(clean)
    assert [rt.channel for rt in rts] == ["u_B_DE", "i_CM"]
    for rt in rts:
        bt = rt.term(fam, (), P)
        y = bt.output(P)
        err = np.sqrt(np.mean((y - rt.prep.bearing) ** 2) / np.mean(rt.prep.bearing ** 2))
        assert err <= 1e-4, (rt.channel, err)
        h = np.stack(rt.model(fam, (), P), axis=1)
        rel = np.abs(h - bt.h_meas) / np.abs(bt.h_meas)
        assert rel.max() <= 1e-6, (rt.channel, rel.max())
        # the channel's own H1, not the bearing voltage's (u_B_DE: up to 56 % apart)
        ub = fam._terms((), P)[1][0].h_meas
        assert np.max(np.abs(bt.h_meas - ub) / np.abs(ub)) > 0.03


@pytest.fixture(scope="module")
def noisy(clean: np.ndarray) -> tuple[PmsmFamily, list[RecordChannelTerm]]:
    """The bench record with white noise: terminals 35 dB below their RMS, u_B and u_B_DE
    30 dB, i_CM 30 dB (about the concealed cases' levels at speed)."""
    rng = np.random.default_rng(7)
    rms = np.std(clean, axis=1) * 10 ** (-np.array([35, 35, 35, 30, 30, 30]) / 20)
    return _family(clean + rms[:, None] * rng.standard_normal(clean.shape))


def test_chi2_at_the_truth_like_the_bearing_channel(
        noisy: tuple[PmsmFamily, list[RecordChannelTerm]]) -> None:
    """At the network that made the data each channel's whitened residual has the level of
    the u_B channel of the same record: chi2 per entry within 0.4-1.3. On this short
    record with white noise all three are below 1 (8 noise seeds, mean chi2/n: u_B 0.56,
    u_B_DE 0.62, i_CM 0.66; seed 7: u_B 0.39 on its 96 entries, u_B_DE 0.72, i_CM 0.74);
    on the concealed cases, with EMI, the detective's final fits give ~1 (diagnose).
    Whitened by another channel's covariance, or with the wrong output, the level is off by
    orders of magnitude."""
    fam, rts = noisy
    for rt in rts:
        r = np.concatenate(rt.residual(fam, (), P)[0])
        assert 0.4 <= r @ r / r.size <= 1.3, (rt.channel, r @ r / r.size)


def test_jacobian_matches_central_differences(
        noisy: tuple[PmsmFamily, list[RecordChannelTerm]],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The analytic (adjoint) Jacobian of each channel (14 names: more than the 12 up to
    which a record term takes forward differences, so the adjoint path) against central
    differences (step 1e-4 in ln p) of its residual with direct solves (sparse LU per record
    bin; the pole-residue transfer, accurate to 1e-5 of the largest response, is not
    accurate enough for the small low-frequency i_CM columns: 19 % off on winding.U.R_w)
    on four columns: within 2 % of their norm (the bearing channels' standard, dH/H
    interpolated over the record bins; measured at most 0.05 %). A name the network does not
    have at that speed gives a zero column."""
    fam, rts = noisy
    names = (*tuple(n for n in machine_names(P, SPEC) if n in P)[::3][:10],
             "insulation.C_wr", "lubricant.C_1", "lubricant.R_1", "x@100rpm")
    jms = [np.concatenate(rt.residual(fam, (), P, names)[1]) for rt in rts]
    monkeypatch.setattr(transfer, "transfer_on",
                        lambda mna, b, cout, v, f: mna.solve(f, b, cout, v, method="sparse").h)
    h = 1e-4
    for rt, jm in zip(rts, jms, strict=True):
        assert np.all(jm[:, -1] == 0)                     # not a name of this speed
        for n in ("winding.U.R_w", "airgap.C_rf", "insulation.C_wr", "lubricant.C_1"):
            k = names.index(n)
            rp = rt.residual(fam, (), P.with_values({n: P[n] * np.exp(h)}))[0]
            rm = rt.residual(fam, (), P.with_values({n: P[n] * np.exp(-h)}))[0]
            fd = (np.concatenate(rp) - np.concatenate(rm)) / (2 * h)
            err = np.linalg.norm(fd - jm[:, k]) / np.linalg.norm(fd)
            assert err <= 0.02, (rt.channel, n, err)


def test_dataset_without_the_channels_keeps_its_channel_list(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """pmsm_two_layer_x with and without u_B_DE/i_CM (the staged identification replaced by
    the default values: the channel list does not depend on it): without them the channel
    list is exactly the previous one (six spectra, three bearing channels per speed, the
    shaft-to-frame spectra), with identical data; with them six more per speed, last."""
    from vfmodel.core.io_dataset import read_dataset

    def fake_identify(ds: Any, effects: Any, sections: Any, **kw: Any) -> Any:
        return SimpleNamespace(params=default_params(), speeds=(),
                               spec=NetSpec(effects, kw.get("n_rungs", 3), sections[0]))

    monkeypatch.setattr(pmsm, "identify", fake_identify)
    ds = read_dataset(REPO / "data" / "concealed" / "pmsm_two_layer_x")
    bare = replace(ds, recordings=tuple(
        Recording(r.fs, r.data[:4], r.channels[:4], r.speed_rpm) for r in ds.recordings))
    fam = pmsm_family(ds, ("lubricant_two_layer",), fit_points=31)
    fam0 = pmsm_family(bare, ("lubricant_two_layer",), fit_points=31)
    old = [c.where for c in fam0.channels]
    speeds = ("0", "100", "300")
    assert old == ([f"impedance:{t}" for t in ("U-Frame", "V-Frame", "W-Frame", "U-V",
                                                "V-W", "W-U")]
                   + [f"bearing:{s}rpm:{ph}" for s in speeds for ph in "UVW"]
                   + ["impedance:Shaft-Frame", "impedance:Shaft-Frame@100rpm",
                      "impedance:Shaft-Frame@300rpm"]), old
    assert fam0.records == ()
    new = [c.where for c in fam.channels]
    assert new[:len(old)] == old
    assert new[len(old):] == [f"{k}:{s}rpm:{ph}" for s in speeds
                              for k in ("bearing_de", "i_cm") for ph in "UVW"]
    for a, b in zip(fam0.channels, fam.channels, strict=False):
        np.testing.assert_array_equal(a.measured, b.measured)
        np.testing.assert_array_equal(a.sigma, b.sigma)
    r0 = fam0.residual((), fam0.start)
    names = ("insulation.C_wr", "lubricant.C_1@100rpm")
    r1, j1 = fam.residual_jacobian((), fam.start, names)
    np.testing.assert_array_equal(r1[:r0.size], r0)
    assert r1.size == r0.size + sum(2 * c.n for c in fam.channels[len(old):])
    # the same from the evaluation pool (every term in a worker, the channels in order)
    with fam.evaluation_pool((), fam.start, names):
        r2, j2 = fam.residual_jacobian((), fam.start, names)
    np.testing.assert_array_equal(r2, r1)
    np.testing.assert_array_equal(j2, j1)
