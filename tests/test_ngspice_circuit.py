"""MNA against ngspice: random RLC networks, exported/imported netlists, runner errors."""

from __future__ import annotations

import numpy as np
import pytest

from benches.random_networks import random_rlc_network
from vfmodel.circuit.netlist import Circuit
from vfmodel.circuit.ngspice import run_ac, run_tran
from vfmodel.circuit.spice_export import spice_names, to_spice
from vfmodel.circuit.spice_import import from_spice
from vfmodel.errors import SimulatorError

pytestmark = pytest.mark.ngspice


def _compare(c: Circuit, points_per_decade: int = 20) -> float:
    _, nmap = spice_names(c)
    probes = [f"v({nmap[n]})" for n in c.nodes] + ["i(V1)"]
    res = run_ac(to_spice(c), probes, f_start_hz=100.0, f_stop_hz=1e7,
                 points_per_decade=points_per_decade)
    assert res.freq_hz[0] == pytest.approx(100.0) and res.freq_hz[-1] == pytest.approx(1e7)
    ours = c.ac(res.freq_hz, [*c.nodes, "i(V1)"])
    # relative to |ngspice| point by point; nodes tied to ground by a closed switch are
    # exactly 0 in both (absolute floor 1e-300)
    return float(np.max(np.abs(ours - res.values) / np.maximum(np.abs(res.values), 1e-300)))


def test_twenty_random_networks_match_ngspice() -> None:
    worst = 0.0
    n_sw = n_k = 0
    for seed in range(20):
        c = random_rlc_network(np.random.default_rng(seed), n_nodes=14, n_elements=34)
        assert len(c) >= 30
        n_sw += sum(e.kind == "switch" for e in c.elements)
        n_k += sum(e.kind == "mutual" for e in c.elements)
        worst = max(worst, _compare(c))
    assert n_sw >= 20 and n_k >= 20  # switches (open and closed) and couplings are exercised
    assert worst < 1e-6, worst


def test_imported_netlist_matches_ngspice() -> None:
    text = """ladder with coupling
V1 in 0 DC 0 AC 1
R1 in a 50
L1 a b 1u
C1 b 0 1n
L2 b c 2.2u
C2 c 0 470p
R2 c 0 1k
K1 L1 L2 0.4
I1 0 c AC 1m
.end
"""
    c = from_spice(text)
    res = run_ac(text, ["v(b)", "v(c)", "i(V1)"], f_start_hz=100.0, f_stop_hz=1e7,
                 points_per_decade=10)
    ours = c.ac(res.freq_hz, ["b", "c", "i(V1)"])
    assert np.max(np.abs(ours - res.values) / np.abs(res.values)) < 1e-6


def test_greybox_style_netlist_with_named_nodes_and_sources() -> None:
    # nodes U, V, W, SN and hierarchical names survive export; transfer U,V,W -> SN
    c = Circuit(title="grey-box style")
    for ph in "UVW":
        c = c.add_vsource(f"src.{ph}", ph, "0", 1.0)
        c = c.add_resistor(f"winding.{ph}.R", ph, f"star.{ph}", 0.5)
        c = c.add_inductor(f"winding.{ph}.L", f"star.{ph}", "N", 1e-4)
        c = c.add_capacitor(f"insulation.{ph}.C", ph, "0", 2e-10)
        c = c.add_capacitor(f"airgap.{ph}.C", f"star.{ph}", "SN", 1e-11)
    c = (c.add_capacitor("rotor.C", "SN", "0", 1e-10)
         .add_resistor("bearing.nde.lubricant.oil.R", "SN", "0", 1e6)
         .add_capacitor("bearing.nde.lubricant.oil.C", "SN", "0", 5e-11)
         .add_switch("bearing.nde.contact.S", "SN", "0", closed=False)
         .add_resistor("neutral.R", "N", "0", 1e7))
    text = to_spice(c)
    assert "\nV_src_U U 0 " in text and "R_bearing_nde_lubricant_oil_R SN 0 " in text
    res = run_ac(text, ["v(SN)"], f_start_hz=100.0, f_stop_hz=1e7, points_per_decade=10)
    h = c.transfer(["src.U", "src.V", "src.W"], ["SN"])(res.freq_hz)
    # ngspice drives all three sources at once: superposition of the three transfers
    assert np.max(np.abs(h.sum(axis=2)[:, 0] - res.values[:, 0]) / np.abs(res.values[:, 0])) \
        < 1e-6


def test_runner_reports_ngspice_errors() -> None:
    with pytest.raises(SimulatorError, match="unknown parameter"):
        run_ac("t\nV1 a 0 AC 1\nR1 a 0 xx\n", ["v(a)"], f_start_hz=1.0, f_stop_hz=10.0)
    with pytest.raises(SimulatorError, match="no such vector"):
        run_ac("t\nV1 a 0 AC 1\nR1 a 0 1k\n", ["v(zz)"], f_start_hz=1.0, f_stop_hz=10.0)
    with pytest.raises(SimulatorError, match="probe"):
        run_ac("t\nV1 a 0 AC 1\nR1 a 0 1k\n", ["a"], f_start_hz=1.0, f_stop_hz=10.0)


def test_runner_tran_rc_step_analytic() -> None:
    # RC low-pass driven by a 1 V ramp of T = 1 ns: for t > T (analytic)
    # v = 1 - (tau/T) (exp(T/tau) - 1) exp(-t/tau)
    net = "rc\nV1 in 0 PWL(0 0 1n 1)\nR1 in out 1k\nC1 out 0 1n\n"
    res = run_tran(net, ["v(out)"], t_step_s=1e-8, t_stop_s=5e-6, t_max_s=1e-9,
                   options={"reltol": 1e-6})
    t = res.time_s
    assert np.allclose(np.diff(t), 1e-8, rtol=1e-9)
    late = t > 1e-7
    tau, ramp = 1e-6, 1e-9
    ref = 1 - (tau / ramp) * np.expm1(ramp / tau) * np.exp(-t[late] / tau)
    assert np.max(np.abs(res["v(out)"][late] - ref)) < 1e-5
