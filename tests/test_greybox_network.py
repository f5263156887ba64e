"""Grey-box network: substructures against analytic impedances, assembly limits, effects."""

from __future__ import annotations

from typing import cast

import numpy as np
import pytest

from vfmodel.circuit.netlist import Circuit, Element
from vfmodel.greybox.assembly import (
    PHASES,
    SOURCES,
    bearing_transfer,
    build_network,
    default_params,
    topology_impedance,
)
from vfmodel.greybox.bearing import divider_capacitances
from vfmodel.greybox.effects import EFFECT_INFO, PAPER_EFFECTS
from vfmodel.greybox.params import ParamSet, ParamSpec
from vfmodel.greybox.substructures import insulation, ladder_values, rl_ladder, rl_plain


def _z(els: list[Element], a: str, f: np.ndarray) -> np.ndarray:
    return Circuit(elements=tuple(els)).port_impedance(f, [(a, "0")])[:, 0, 0]


F = np.logspace(1, 8, 29)


def test_rl_ladder_matches_recursive_formula() -> None:
    # reference: Z = jw L_ext + R_0 + (jw L_0 || (R_1 + (jw L_1 || (... R_n-1 + jw L_n-1))))
    r_dc, l_ext, l_int, rho, n = 2e-3, 5e-9, 8e-9, 3.0, 5
    z = _z(rl_ladder("lad", "a", "0", r_dc=r_dc, l_ext=l_ext, l_int=l_int, rho=rho,
                     n_rungs=n), "a", F)
    rs, ls = ladder_values(r_dc, l_int, rho, n)
    w = 2j * np.pi * F
    inner: np.ndarray = rs[n - 1] + w * ls[n - 1]
    for k in range(n - 2, -1, -1):
        inner = rs[k] + (w * ls[k] * inner) / (w * ls[k] + inner)
    ref = w * l_ext + inner
    assert np.max(np.abs(z - ref) / np.abs(ref)) < 1e-10
    # DC resistance r_dc and low-frequency inductance l_ext + l_int
    z0 = _z(rl_ladder("lad", "a", "0", r_dc=r_dc, l_ext=l_ext, l_int=l_int, rho=rho,
                      n_rungs=n), "a", np.array([1e-2]))[0]
    assert abs(z0.real / r_dc - 1) < 1e-9
    assert abs(z0.imag / (2 * np.pi * 1e-2) / (l_ext + l_int) - 1) < 1e-6
    # skin effect: resistance rises monotonically, by more than rho between the band edges
    assert np.all(np.diff(z.real) >= -1e-15) and z.real[-1] / z.real[0] > rho


def test_rl_plain_and_insulation_analytic() -> None:
    w = 2j * np.pi * F
    z = _z(rl_plain("p", "a", "0", r=0.1, l_h=1e-6), "a", F)
    assert np.max(np.abs(z - (0.1 + w * 1e-6)) / np.abs(0.1 + w * 1e-6)) < 1e-12
    c, r, k, tau = 1e-9, 1e8, 0.2, 2e-6
    z = _z(insulation("ins", "a", "0", c=c, r_ins=r, loss=True, k_d=k, tau_d=tau), "a", F)
    c_d = k * c
    ref: np.ndarray = 1 / (1 / r + w * c + 1 / (tau / c_d + 1 / (w * c_d)))
    assert np.max(np.abs(z - ref) / np.abs(ref)) < 1e-10
    z = _z(insulation("ins", "a", "0", c=c, r_ins=r, loss=False), "a", F)
    ref = 1 / (1 / r + w * c)
    assert np.max(np.abs(z - ref) / np.abs(ref)) < 1e-10


def test_cm_impedance_low_frequency_is_total_capacitance() -> None:
    # standstill (rotor grounded by the metallic contact), f = 100 Hz: the winding is one
    # node; Y = sum over the 6 insulation paths of 1/R + jwC + jw k C / (1 + jw tau)
    # plus jw C_t of the three terminals (winding, frame and shaft impedances negligible)
    p = default_params()
    f = np.array([100.0])
    w = 2j * np.pi * f[0]
    z = topology_impedance(p, f, ["U-Frame"])["U-Frame"][0]
    k, tau, r = p["insulation.k_d"], p["insulation.tau_d"], p["insulation.R_ins"]
    y = 0j
    for ph in PHASES:
        for c in (p[f"winding.{ph}.C_wf"], p["insulation.C_wr"]):
            y += 1 / r + w * c + w * k * c / (1 + w * tau)
        y += w * p[f"winding.{ph}.C_t"]
    assert abs(z * y - 1) < 1e-6
    c_total = (y / w).real
    assert 4e-9 < c_total < 7e-9   # paper-like: a few nF to frame


def _divider_params() -> ParamSet:
    # film and insulation resistances at their upper bounds: capacitive divider at 1 kHz
    # (film RC corner 1/(2 pi 1e9 * 20 nF) = 8 mHz; first winding resonance ~270 kHz gives a
    # (f/f0)^2 ~ 1.4e-5 deviation at 1 kHz)
    return default_params().with_values({"lubricant.R_1": 1e9, "insulation.R_ins": 1e12})


def test_bvr_rotating_equals_capacitive_divider() -> None:
    eff = {"metallic_contact", "hertzian_edge_capacitance"}
    p = _divider_params()
    h = bearing_transfer(p, eff, "rotating")(np.array([1e3]))[0, 0, :]
    d = divider_capacitances(p, eff)
    # per-phase share of the divider: C_wr/3 / (C_wr + C_rf + 2 C_b)
    assert np.allclose(h.real, d["bvr"] / 3, rtol=1e-4)
    assert np.all(np.abs(h.imag) < 1e-4 * d["bvr"])
    assert abs(d["bvr"] - 0.0158) < 0.002     # paper Table IV: 1.62 % at 100 rpm


def test_switch_closed_shorts_film_and_with_switches_agrees() -> None:
    p = _divider_params()
    f = np.array([1e4])
    hs = bearing_transfer(p, PAPER_EFFECTS, "standstill")(f)[0, 0, :].sum()
    hr = bearing_transfer(p, PAPER_EFFECTS, "rotating")(f)[0, 0, :].sum()
    # metallic contact: u_B is only the drop of the CM current (jw C_total ~ 3.5e-4 A/V at
    # 10 kHz) on the frame (|1 mOhm + jw 17 nH| ~ 1.4 mOhm): ~5e-7 V/V, 3.5e-5 of the divider
    assert abs(hs) < 1e-3 * abs(hr)
    c = build_network(p, PAPER_EFFECTS, "standstill", sources=True)
    opened = c.with_switches({"bearing.NDE.contact": False, "bearing.DE.contact": False})
    h2 = opened.mna.response(f, SOURCES, ("SN",))[0, 0, :].sum()
    assert abs(h2 - hr) < 1e-12 * abs(hr)


_MARKERS = {
    "winding_skin_effect": "winding.U.s1.rl.R1",
    "insulation_dielectric_loss": "airgap.C_d",
    "frame_skin_effect": "frame.R1",
    "shaft_skin_effect": "shaft.1.R1",
    "ball_skin_effect": "bearing.NDE.ball.R1",
    "lubricant_dielectric_loss": "bearing.NDE.lubricant.oil.C_d",
    "lubricant_two_layer": "bearing.DE.lubricant.thickener.C",
    "hertzian_edge_capacitance": "bearing.NDE.C_edge",
    "metallic_contact": "bearing.DE.contact",
}


@pytest.mark.parametrize("effect", sorted(_MARKERS))
def test_each_effect_toggles_its_elements(effect: str) -> None:
    p = default_params()
    full = {el.name for el in build_network(p, PAPER_EFFECTS).elements}
    less = {el.name for el in build_network(p, PAPER_EFFECTS - {effect}).elements}
    added = full - less
    assert _MARKERS[effect] in added
    # every added element belongs to a location the vocabulary names for the effect
    prefixes = cast(str | tuple[str, ...], {
        "winding_skin_effect": "winding.", "insulation_dielectric_loss": ("insulation", "airgap"),
        "frame_skin_effect": "frame.", "shaft_skin_effect": "shaft.",
        "ball_skin_effect": "bearing.", "lubricant_dielectric_loss": "bearing.",
        "lubricant_two_layer": "bearing.", "hertzian_edge_capacitance": "bearing.",
        "metallic_contact": "bearing."}[effect])
    assert all(n.startswith(prefixes) for n in added)
    assert effect in EFFECT_INFO


def test_fixture_inductance_adds_jwl() -> None:
    p = default_params()
    f = np.logspace(3, 7, 9)
    z0 = topology_impedance(p, f, ["U-V"], PAPER_EFFECTS)["U-V"]
    z1 = topology_impedance(p, f, ["U-V"], PAPER_EFFECTS | {"fixture_inductance"})["U-V"]
    assert np.allclose(z1 - z0, 2j * np.pi * f * p["fixture.L"], rtol=1e-9, atol=0)


def test_paramset_log_roundtrip_and_bounds() -> None:
    ps = default_params()
    u = ps.to_unit()
    assert np.all((u >= 0) & (u <= 1))
    back = ps.from_unit(u)
    assert np.allclose(back.vector, ps.vector, rtol=1e-12)
    rng = np.random.default_rng(1)
    pert = ps.perturbed(rng, 5.0)   # huge perturbation: clipped into the bounds
    assert np.all(pert.vector >= ps.lower) and np.all(pert.vector <= ps.upper)
    with pytest.raises(ValueError, match="bounds"):
        ParamSpec("x", 2.0, 3.0, 4.0, "g")


@pytest.mark.ngspice
def test_assembly_impedance_matches_ngspice() -> None:
    from vfmodel.circuit.ngspice import ngspice_available, run_ac
    from vfmodel.circuit.spice_export import to_spice

    if not ngspice_available():
        pytest.skip("ngspice not installed")
    p = default_params()
    c = build_network(p, PAPER_EFFECTS, "standstill")
    c_i = c.add(Element("Itest", "isource", ("0", "U"), 1.0))   # unit current into U
    res = run_ac(to_spice(c_i), ["v(U)"], f_start_hz=1e3, f_stop_hz=1e7, points_per_decade=20)
    z = topology_impedance(p, res.freq_hz, ["U-Frame"])["U-Frame"]
    assert np.max(np.abs(res.values[:, 0] - z) / np.abs(z)) < 1e-6


@pytest.mark.parametrize("state", ["standstill", "rotating"])
@pytest.mark.parametrize("n_sections", [2, 3])
def test_network_values_without_rebuilding_the_netlist(state: str, n_sections: int) -> None:
    """The identification's element values (no netlist built) are the netlist's own."""
    from vfmodel.greybox.assembly import network_values
    from vfmodel.greybox.effects import ALL_EFFECTS

    p = default_params().perturbed(np.random.default_rng(3), 0.3)
    for eff in (PAPER_EFFECTS, ALL_EFFECTS, frozenset()):
        ref = build_network(p, eff, state, n_sections=n_sections,  # type: ignore[arg-type]
                            sources=True).param_values
        got = network_values(p, eff, state, n_sections=n_sections)  # type: ignore[arg-type]
        np.testing.assert_array_equal(got, ref)


def test_log_chain_rule_equals_its_definition() -> None:
    # objective._chain: sum_e dH/dv_e v_e dlog v_e/dlog p_j as a matrix product; reference:
    # the same sum written as an einsum; with no element moved (e.g. only the fixture
    # inductance fitted) the derivatives are zero, not an error
    from vfmodel.greybox.objective import _chain

    rng = np.random.default_rng(3)
    dv = rng.normal(size=(7, 3, 5)) + 1j * rng.normal(size=(7, 3, 5))
    v, dl = rng.random(5), rng.random((5, 4))
    ref = np.einsum("fie,e,ej->fij", dv, v, dl)
    assert np.max(np.abs(_chain(dv, v, dl) - ref)) <= 1e-12 * np.max(np.abs(ref))
    empty = _chain(dv[..., :0], v[:0], dl[:0])
    assert empty.shape == (7, 3, 4) and not np.any(empty)
