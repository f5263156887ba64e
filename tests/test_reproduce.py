"""``vfmodel reproduce`` and ``predict`` end to end on a small virtual bench.

The bench (scripts/make_testbench.py, one PWM period per record, 81 impedance points,
0 and 200 rpm, 2-coil truth network) is small so the test stays fast; the acceptance
numbers on data/pmsm40kw come from scripts/bench_reproduce.py.
"""

from __future__ import annotations

import json
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from tests.conftest import load_script
from vfmodel.circuit.ngspice import run_ac
from vfmodel.circuit.spice_import import from_spice
from vfmodel.cli.main import main
from vfmodel.core.io_dataset import read_dataset
from vfmodel.greybox.assembly import TOPOLOGY_PORTS, param_specs
from vfmodel.greybox.network import NetSpec
from vfmodel.greybox.params import ParamSet
from vfmodel.signals.filters import brickwall_filter

ROOT = Path(__file__).resolve().parents[1]


def _script() -> ModuleType:
    return load_script("make_testbench")


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, dict[str, Any]]:
    root = tmp_path_factory.mktemp("repro")
    ds = root / "bench"
    truth = _script().make_bench(ds, seed=2, speeds=(0.0, 200.0), periods=1, n_freq=81,
                                 n_coils=2, n_rungs=4)
    out = root / "out"
    code = main(["reproduce", str(ds), "--out", str(out), "--sections", "2",
                 "--max-nfev", "12", "--quiet"])
    assert code == 0
    return ds, out, truth


def test_outputs_and_contract_keys(run: tuple[Path, Path, dict[str, Any]]) -> None:
    _, out, _ = run
    r = json.loads((out / "results.json").read_text())
    topo = list(TOPOLOGY_PORTS)
    for t in topo:
        assert set(r["impedance"][t]) >= {"mape_pct", "coherence"}
        assert 0.0 <= r["impedance"][t]["coherence"] <= 1.0
    assert r["impedance"]["mean_mape_pct"] == pytest.approx(
        np.mean([r["impedance"][t]["mape_pct"] for t in topo]), rel=1e-12)
    for k in ("0", "200"):
        b = r["bearing"][k]
        assert set(b) >= {"peak_measured_v", "peak_model_v", "abs_err_v", "rel_err_pct",
                          "spectral_corr", "lubricant", "residual_rms_v"}
        assert b["residual_rms_v"] > 0.0
        assert set(b["lubricant"]) == {"r_ohm", "c_f"}
        assert b["abs_err_v"] == pytest.approx(abs(b["peak_model_v"] - b["peak_measured_v"]))
        assert b["rel_err_pct"] == pytest.approx(100 * b["abs_err_v"] / b["peak_measured_v"])
        # peaks on the settled window (20 us after the start to 3 us before the end), a
        # part of the whole record
        t0, t1 = b["compared_s"]
        assert t0 == pytest.approx(20e-6, rel=1e-6) and 0.0 < t1 - t0
        whole = b["peak_whole_record"]
        assert b["peak_measured_v"] <= whole["measured_v"]
        assert b["peak_model_v"] <= whole["model_v"]
        bl = r["baseline_bvr"][k]
        assert set(bl) >= {"bvr", "c_b_f", "peak_model_v", "rel_err_pct"}
    assert r["bearing"]["mean_rel_err_pct_rotating"] == pytest.approx(
        r["bearing"]["200"]["rel_err_pct"])
    for f in ("report.html", "network_0rpm.cir", "network_200rpm.cir",
              "fig19_impedance_cm.png", "fig20_22_bearing_200rpm.png", "fig23_lubricant.png"):
        assert (out / f).stat().st_size > 200, f
    page = (out / "report.html").read_text()   # self-contained: figures embedded
    assert "<img src='data:image/png;base64," in page
    assert "data-name='fig19_impedance_cm.png'" in page


def test_numbers_against_the_bench(run: tuple[Path, Path, dict[str, Any]]) -> None:
    ds, out, truth = run
    r = json.loads((out / "results.json").read_text())
    data = read_dataset(ds)
    rec = data.recording_at(200.0)
    # peak of the measured record after the 10 MHz brickwall filter (CONTRACT section 6)
    assert r["bearing"]["200"]["peak_measured_v"] == pytest.approx(
        float(np.max(np.abs(brickwall_filter(rec.bearing, rec.fs, 10e6)))), rel=1e-12)
    # the identified network's CM capacitance at 1 kHz: the bench's noise-free value to 2 %
    m = r["model"]
    p = ParamSet.from_specs(param_specs()).with_values(m["params"])
    spec = NetSpec(frozenset(m["effects"]), m["n_rungs"], m["n_sections"])
    z = spec.build(p, "standstill").port_impedance(np.array([1e3]), [("U", "0")])[0, 0, 0]
    c_1k = -1 / (2 * np.pi * 1e3 * z.imag)
    assert c_1k == pytest.approx(truth["impedance"]["U-Frame"]["c_1khz_f"], rel=0.02)
    # BVR model consistency: eq. 1 with the reported capacitances
    bl = r["baseline_bvr"]["200"]
    c_wr, c_rf = r["baseline_bvr"]["c_wr_f"], r["baseline_bvr"]["c_rf_f"]
    assert bl["bvr"] == pytest.approx(c_wr / (c_wr + c_rf + 2 * bl["c_b_f"]), rel=1e-12)
    # standstill: metallic contact, the average BVR is ~0 -> C_b at its upper limit
    assert r["baseline_bvr"]["0"]["c_b_f"] is None
    # the grey box reproduces the 200 rpm peak to 10 % and beats the divider model
    assert r["bearing"]["200"]["rel_err_pct"] < 10.0
    assert r["bearing"]["200"]["rel_err_pct"] < r["baseline_bvr"]["200"]["rel_err_pct"]
    assert r["bearing"]["0"]["rel_err_pct"] < r["baseline_bvr"]["0"]["rel_err_pct"]


def test_film_resistance_bound_follows_its_time_constant(
        run: tuple[Path, Path, dict[str, Any]]) -> None:
    """results.json's film R interval at speed: a lower bound alone exactly when 2 pi times
    the 95 % upper end of the film's time constant exceeds the record's duration (n / fs of
    the recording), two-sided otherwise; strict JSON either way (greybox.lsq.lower_bound_only)."""
    ds, out, _ = run

    def refuse(token: str) -> None:
        raise AssertionError(f"results.json holds {token}")

    r = json.loads((out / "results.json").read_text(), parse_constant=refuse)
    rec = read_dataset(ds).recording_at(200.0)
    iv = r["bearing"]["200"]["lubricant_interval"]["r_ohm"]
    assert iv["record_s"] == pytest.approx(rec.bearing.size / rec.fs, rel=1e-12)
    tau_hi = iv["time_constant_s"]["hi"]
    slow = tau_hi is None or 2 * np.pi * tau_hi > iv["record_s"]
    assert iv["bound"] == ("lower" if slow else "two-sided")
    assert (iv["hi"] is None) == slow
    assert iv["value"] == pytest.approx(r["bearing"]["200"]["lubricant"]["r_ohm"], rel=1e-12)
    if iv["lo"] is not None:
        assert iv["lo"] < iv["value"]


def test_netlist_reproduces_model_impedance(run: tuple[Path, Path, dict[str, Any]]) -> None:
    _, out, _ = run
    r = json.loads((out / "results.json").read_text())
    m = r["model"]
    p = ParamSet.from_specs(param_specs()).with_values(m["params"])
    spec = NetSpec(frozenset(m["effects"]), m["n_rungs"], m["n_sections"])
    circ = from_spice((out / "network_0rpm.cir").read_text())
    f = np.logspace(3, 7, 21)
    pairs = [TOPOLOGY_PORTS[t] for t in TOPOLOGY_PORTS]
    z_cir = circ.port_impedance(f, pairs)
    z_model = spec.build(p, "standstill").port_impedance(f, pairs)
    assert np.max(np.abs(z_cir - z_model) / np.abs(z_model)) < 1e-9


@pytest.mark.ngspice
def test_ngspice_ac_of_exported_network(run: tuple[Path, Path, dict[str, Any]]) -> None:
    _, out, _ = run
    text = (out / "network_0rpm.cir").read_text()
    circ = from_spice(text)
    worst = 0.0
    for a, b in TOPOLOGY_PORTS.values():
        bb = "0" if b == "0" else b
        net = text.replace("\n.end", f"\nIZ {bb} {a} DC 0 AC 1\n.end")
        probe = f"v({a})" if b == "0" else f"v({a},{b})"
        res = run_ac(net, [probe], f_start_hz=1e3, f_stop_hz=1e7, points_per_decade=10)
        z = circ.port_impedance(res.freq_hz, [(a, b)])[:, 0, 0]
        worst = max(worst, float(np.max(np.abs(res.values[:, 0] - z) / np.abs(z))))
    assert worst < 1e-6, worst


def test_predict_from_netlist(run: tuple[Path, Path, dict[str, Any]]) -> None:
    ds, out, _ = run
    r = json.loads((out / "results.json").read_text())
    pdir = out / "pred"
    rec = ds / "recordings" / "rpm0200.npz"
    assert main(["predict", str(out / "network_200rpm.cir"), str(rec), "--out", str(pdir),
                 "-q"]) == 0
    s = json.loads((pdir / "prediction.json").read_text())
    # the same network and inputs as the reproduce validation: the same periodic response
    b = r["bearing"]["200"]
    assert s["peak_model_v"] == pytest.approx(b["peak_model_periodic_v"], rel=1e-6)
    # reproduce adds the initial-state correction estimated from the record; the bench's
    # records are periodic steady states, so it is small there
    assert b["peak_model_v"] == pytest.approx(b["peak_model_periodic_v"], rel=5e-3)
    assert s["peak_measured_v"] == pytest.approx(r["bearing"]["200"]["peak_measured_v"],
                                                 rel=1e-12)
    assert main(["predict", str(out / "network_200rpm.cir"), "--inverter",
                 "v_dc=270,speed_rpm=200,n_periods=1", "--out", str(pdir / "inv"), "-q"]) == 0
    s2 = json.loads((pdir / "inv" / "prediction.json").read_text())
    assert 0.1 < s2["peak_model_v"] < 20.0
    assert main(["predict", str(out / "network_200rpm.cir"), "--inverter", "bogus=1",
                 "--out", str(pdir / "bad"), "-q"]) == 2


def test_added_effect_reaches_the_network(run: tuple[Path, Path, dict[str, Any]],
                                          tmp_path: Path) -> None:
    """``--add-effect endwinding_capacitance``: the identified network has it (results.json
    ``model.effects``), the exported netlist carries the three phase-to-phase capacitors at
    the fitted ``winding.C_pp`` and still reproduces the model's impedance (1e-9); an
    unknown effect is refused before anything is written (exit 2)."""
    ds, _, _ = run
    out = tmp_path / "out"
    assert main(["reproduce", str(ds), "--out", str(out), "--sections", "2", "--max-nfev",
                 "12", "--no-blackbox", "--add-effect", "endwinding_capacitance",
                 "--max-nfev-lubricant", "5", "--lubricant-random-starts", "0",
                 "--quiet"]) == 0
    m = json.loads((out / "results.json").read_text())["model"]
    assert "endwinding_capacitance" in m["effects"]
    # the lubricant options reach the fit: its stage stops at the 5 evaluations asked for
    # (status 0: limit reached; with the defaults this stage converges after 17)
    lub = [s for s in m["stages"] if s["name"].startswith("lubricant")]
    assert lub and all(s["nfev"] <= 5 and s["status"] == 0 for s in lub)
    circ = from_spice((out / "network_0rpm.cir").read_text())
    caps = {e.name: e.value for e in circ.elements if e.kind == "capacitor"
            and {e.nodes[0], e.nodes[1]} in ({"U", "V"}, {"V", "W"}, {"W", "U"})}
    assert len(caps) == 3
    for v in caps.values():
        assert v == pytest.approx(m["params"]["winding.C_pp"], rel=1e-12)
    p = ParamSet.from_specs(param_specs()).with_values(m["params"])
    spec = NetSpec(frozenset(m["effects"]), m["n_rungs"], m["n_sections"])
    f = np.logspace(3, 7, 21)
    pairs = [TOPOLOGY_PORTS[t] for t in TOPOLOGY_PORTS]
    z_model = spec.build(p, "standstill").port_impedance(f, pairs)
    assert np.max(np.abs(circ.port_impedance(f, pairs) - z_model) / np.abs(z_model)) < 1e-9
    bad = tmp_path / "bad"
    assert main(["reproduce", str(ds), "--out", str(bad), "--add-effect", "bogus",
                 "--quiet"]) == 2
    assert not bad.exists()
