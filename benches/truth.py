"""The virtual machine of the test bench: a network richer than the grey-box model.

Differences from :func:`vfmodel.greybox.assembly.build_network` (what the identified model
has to approximate):

- each phase is a chain of ``n_coils`` coils (each an RL ladder of ``n_rungs`` rungs with
  its own ``R_p`` and ``C_s``) instead of two sections, with a random per-coil asymmetry;
- winding-to-frame and winding-to-rotor capacitances are distributed over the coil
  junctions (with asymmetry) instead of lumped at a midpoint;
- end-winding phase-to-phase capacitances between the terminals;
- DE and NDE bearings differ (``bearing_asym``);
- every ladder has more rungs.

The lubricant state follows the trends of the paper's Fig. 23 (:func:`lubricant_at_speed`):
with speed the film resistance rises and its capacitance falls.

References
----------
Reference paper (grey-box bearing-voltage model of a 40-kW PMSM): Sec. II (four parallel
branches of two coils per phase), Figs. 12-17, Fig. 23, Table IV.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vfmodel._choices import BearingState, check_choice
from vfmodel.circuit.netlist import Circuit, Element
from vfmodel.greybox.assembly import BEARING_NODE, PHASES, TAPER_NAMES, default_params
from vfmodel.greybox.effects import ALL_EFFECTS, PAPER_EFFECTS, check_effects
from vfmodel.greybox.params import ParamSet
from vfmodel.greybox.substructures import (
    bearing,
    capacitor,
    insulation,
    rl_branch,
    winding_section,
)

__all__ = [
    "BENCH_VARIANTS",
    "TruthDetail",
    "build_truth_network",
    "lubricant_at_speed",
    "truth_detail",
    "truth_params",
]


BENCH_VARIANTS: dict[str, frozenset[str]] = {
    "paper": PAPER_EFFECTS,
    "fixture": ALL_EFFECTS,
    "single_layer": PAPER_EFFECTS - {"lubricant_two_layer"},
    "no_edge": PAPER_EFFECTS - {"hertzian_edge_capacitance"},
    "no_loss": PAPER_EFFECTS - {"insulation_dielectric_loss", "lubricant_dielectric_loss"},
    "plain_conductors": PAPER_EFFECTS - {"winding_skin_effect", "frame_skin_effect",
                                         "shaft_skin_effect", "ball_skin_effect"},
}
"""Effect sets of the bench's truth network by variant name (``make_testbench --variant``)."""


@dataclass(frozen=True)
class TruthDetail:
    """Structure and asymmetry of the truth network beyond the grey-box parameters.

    Attributes
    ----------
    n_coils : int
        Coils in series per phase.
    n_rungs : int
        Rungs of every RL ladder.
    coil_asym : (3, n_coils, 4) array
        Multiplicative factors per phase and coil for (R and L, R_p, C_s, C to frame/rotor).
    c_pp : float
        End-winding phase-to-phase capacitance (F) between each pair of terminals.
    bearing_asym : float
        DE bearing film capacitance / NDE film capacitance.
    """

    n_coils: int
    n_rungs: int
    coil_asym: NDArray[np.float64]
    c_pp: float
    bearing_asym: float

    def to_json_dict(self) -> dict[str, object]:
        return {"n_coils": self.n_coils, "n_rungs": self.n_rungs,
                "coil_asym": self.coil_asym.tolist(), "c_pp": self.c_pp,
                "bearing_asym": self.bearing_asym}


def truth_detail(rng: np.random.Generator, *, n_coils: int = 4, n_rungs: int = 6,
                 asym_sigma: float = 0.05, c_pp: float = 15e-12,
                 bearing_asym: float = 1.08) -> TruthDetail:
    """Random per-coil asymmetry: log-normal factors of standard deviation ``asym_sigma``."""
    a = np.exp(asym_sigma * rng.standard_normal((3, n_coils, 4)))
    return TruthDetail(n_coils, n_rungs, a, c_pp, bearing_asym)


# per-phase asymmetry of the machine (fixed, like a real machine's V phase in the middle)
_PHASE_ASYM = {"U": 1.00, "V": 0.96, "W": 1.03}


def truth_params(rng: np.random.Generator | None = None, sigma_log: float = 0.0) -> ParamSet:
    """Truth values of the grey-box quantities (calibrated to the paper's magnitudes).

    With ``rng`` and ``sigma_log > 0`` every value is perturbed log-normally (clipped to its
    bounds); this makes the unseen benches.
    """
    p = default_params()
    vals: dict[str, float] = {}
    for ph in PHASES:
        a = _PHASE_ASYM[ph]
        vals[f"winding.{ph}.L_w"] = p[f"winding.{ph}.L_w"] * a
        vals[f"winding.{ph}.C_wf"] = p[f"winding.{ph}.C_wf"] / a
        vals[f"winding.{ph}.C_t"] = p[f"winding.{ph}.C_t"] * a**2
    p = p.with_values(vals)
    if rng is not None and sigma_log > 0:
        # every parameter but the insulation tapers and the end-winding capacitance (the
        # benches were drawn before them; the truth's end-winding capacitance is
        # TruthDetail.c_pp)
        p = p.perturbed(rng, sigma_log, [n for n in p.names
                                         if n not in (*TAPER_NAMES, "winding.C_pp")])
    return p


def lubricant_at_speed(params: ParamSet, speed_rpm: float) -> tuple[ParamSet, BearingState]:
    """Lubricant values and bearing state at ``speed_rpm`` (trends of the paper's Fig. 23).

    ``params`` holds the 100-rpm values. At 0 rpm the bearing is in boundary lubrication
    (metallic contact, ``"standstill"``) with a thin film (2x the 100-rpm capacitance);
    from 100 rpm the film is closed and ``R_1 ~ (n/100)^1.0``, ``C_1 ~ (n/100)^-0.15``,
    ``R_2 ~ (n/100)^0.5``.
    """
    if speed_rpm <= 0:
        return params.with_values({"lubricant.C_1": 2 * params["lubricant.C_1"],
                                   "lubricant.R_1": 0.2 * params["lubricant.R_1"]},
                                  clip=True), "standstill"
    x = max(speed_rpm, 1.0) / 100.0
    return params.with_values({
        "lubricant.R_1": params["lubricant.R_1"] * x**1.0,
        "lubricant.C_1": params["lubricant.C_1"] * x**-0.15,
        "lubricant.R_2": params["lubricant.R_2"] * x**0.5,
    }, clip=True), "rotating"


def build_truth_network(params: ParamSet | Mapping[str, float], detail: TruthDetail,
                        effects: Iterable[str] = PAPER_EFFECTS,
                        state: BearingState = "standstill") -> Circuit:
    """The truth network (same terminal, frame and ``SN`` nodes as the grey-box model).

    ``fixture_inductance`` is not part of the network (it is added to the spectra).
    """
    eff = check_effects(effects)
    check_choice("state", state, BearingState)
    v = params.as_dict() if isinstance(params, ParamSet) else dict(params)
    nc, nr = detail.n_coils, detail.n_rungs
    loss = "insulation_dielectric_loss" in eff
    ins = dict(r_ins=v["insulation.R_ins"], loss=loss, k_d=v["insulation.k_d"],
               tau_d=v["insulation.tau_d"])
    els: list[Element] = []
    for i, p in enumerate(PHASES):
        g = f"winding.{p}"
        nodes = [p] + [f"{p}_c{k}" for k in range(1, nc)] + ["N"]
        asym = detail.coil_asym[i]
        for k in range(nc):
            # two grey-box sections of (R/2, L/2, R_p, C_s) = nc coils of (R/nc, L/nc,
            # 2 R_p / nc, nc C_s / 2) in series
            els += winding_section(
                f"{g}.coil{k}", nodes[k], nodes[k + 1], r=v[f"{g}.R_w"] / nc * asym[k, 0],
                l_h=v[f"{g}.L_w"] / nc * asym[k, 0], r_p=2 * v[f"{g}.R_p"] / nc * asym[k, 1],
                c_s=nc * v[f"{g}.C_s"] / 2 * asym[k, 2],
                skin="winding_skin_effect" in eff, l_frac=v["winding.skin_l_frac"],
                rho=v["winding.skin_rho"], n_rungs=nr)
        els.append(capacitor(f"{g}.C_t", p, "F", v[f"{g}.C_t"]))
        # distributed capacitances at the coil junctions; weights sum to 1
        w = asym[1:, 3] if nc > 1 else np.ones(1)
        w = w / w.sum()
        junctions = nodes[1:-1] if nc > 1 else [nodes[1]]
        for k, (node, wk) in enumerate(zip(junctions, w, strict=True)):
            els += insulation(f"insulation.wf.{p}.{k}", node, "F", c=v[f"{g}.C_wf"] * wk,
                              **ins)  # type: ignore[arg-type]
            els += insulation(f"insulation.wr.{p}.{k}", node, "SM",
                              c=v["insulation.C_wr"] * wk, **ins)  # type: ignore[arg-type]
    for a, b in (("U", "V"), ("V", "W"), ("W", "U")):
        els.append(capacitor(f"endwinding.C_{a}{b}", a, b, detail.c_pp))
    els += insulation("airgap", "SM", "F", c=v["airgap.C_rf"], **ins)  # type: ignore[arg-type]
    els += rl_branch("frame", "F", "0", skin="frame_skin_effect" in eff, r_dc=v["frame.R_dc"],
                     l_ext=v["frame.L_ext"], l_int=v["frame.L_int"], rho=v["frame.rho"],
                     n_rungs=nr)
    for seg, node, lk in (("1", BEARING_NODE, "shaft.L_1"), ("2", "SD", "shaft.L_2")):
        els += rl_branch(f"shaft.{seg}", "SM", node, skin="shaft_skin_effect" in eff,
                         r_dc=v["shaft.R_dc"], l_ext=v[lk], l_int=v["shaft.L_int"],
                         rho=v["shaft.rho"], n_rungs=nr)
    for side, node, fac in (("NDE", BEARING_NODE, 1.0), ("DE", "SD", detail.bearing_asym)):
        els += bearing(
            f"bearing.{side}", node, "F", c_air=v["bearing.C_air"], ball_r=v["ball.R_dc"],
            ball_l_ext=v["ball.L_ext"], ball_l_int=v["ball.L_int"], ball_rho=v["ball.rho"],
            ball_skin="ball_skin_effect" in eff, r_h=v["bearing.R_h"],
            r_1=v["lubricant.R_1"] / fac, c_1=v["lubricant.C_1"] * fac,
            two_layer="lubricant_two_layer" in eff, r_2=v["lubricant.R_2"],
            c_2=v["lubricant.C_2"], lub_loss="lubricant_dielectric_loss" in eff,
            k_d=v["lubricant.k_d"], tau_d=v["lubricant.tau_d"],
            edge="hertzian_edge_capacitance" in eff, c_edge=v["bearing.C_edge"] * fac,
            metallic="metallic_contact" in eff, closed=state == "standstill", n_rungs=nr)
    return Circuit(elements=tuple(els), title="vfmodel bench truth network (40-kW PMSM)")
