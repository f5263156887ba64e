"""Model-structure choice of the identified network: effects, ladder rungs, winding sections.

The paper's winding model splits each phase into two sections (``n_sections = 2``, exactly
:func:`vfmodel.greybox.assembly.build_network`). A winding is a distributed structure, and
its discretisation order is a model-order choice like the rungs of an RL ladder: with
``n_sections = n`` each phase is a chain of ``n`` equal sections ``p -> p_m1 -> ... -> N``
with the same per-phase totals (section ``R_w / n``, ``L_w / n``, ``2 R_p / n`` and
``n C_s / 2``, so that the chain equals the paper's two sections when ``n = 2``), and the
winding-frame and winding-rotor capacitances are spread equally over the ``n - 1``
junctions (with ``(n - 1) R_ins`` each, so the leakage is unchanged). The number of
parameters does not change with ``n``, so the identification can select ``n`` by the
residual (:func:`vfmodel.greybox.identify.identify`). Everything else (terminal
capacitances, air gap, frame, shaft, bearings) is the assembly's.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from vfmodel._choices import BearingState
from vfmodel.circuit.netlist import Circuit, Element
from vfmodel.errors import InputError
from vfmodel.greybox.assembly import PHASES, build_network, with_terminal_sources
from vfmodel.greybox.effects import PAPER_EFFECTS, check_effects
from vfmodel.greybox.params import ParamSet
from vfmodel.greybox.substructures import insulation, winding_section

__all__ = ["NetSpec", "build"]


@dataclass(frozen=True)
class NetSpec:
    """Structure of the model network: effect set, rungs per ladder, winding sections."""

    effects: frozenset[str] = PAPER_EFFECTS
    n_rungs: int = 3
    n_sections: int = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "effects", check_effects(self.effects))
        if self.n_sections < 2 or self.n_rungs < 1:
            raise InputError("n_sections must be >= 2 and n_rungs >= 1",
                             found=f"n_sections={self.n_sections}, n_rungs={self.n_rungs}")

    def build(self, params: ParamSet | Mapping[str, float], state: BearingState = "standstill",
              sources: bool = False) -> Circuit:
        return build(params, self.effects, state, n_rungs=self.n_rungs,
                     n_sections=self.n_sections, sources=sources)

    def to_json_dict(self) -> dict[str, object]:
        return {"effects": sorted(self.effects), "n_rungs": self.n_rungs,
                "n_sections": self.n_sections}


def build(params: ParamSet | Mapping[str, float], effects: Iterable[str] = PAPER_EFFECTS,
          state: BearingState = "standstill", *, n_rungs: int = 3, n_sections: int = 2,
          sources: bool = False) -> Circuit:
    """The grey-box network with ``n_sections`` winding sections per phase (see module)."""
    eff = check_effects(effects)
    base = build_network(params, eff, state, n_rungs=n_rungs, sources=False)
    if n_sections != 2:
        base = _resection(base, params, eff, n_rungs, n_sections)
    return with_terminal_sources(base) if sources else base


def _resection(base: Circuit, params: ParamSet | Mapping[str, float], eff: frozenset[str],
               n_rungs: int, n: int) -> Circuit:
    v = params.as_dict() if isinstance(params, ParamSet) else dict(params)
    drop = [e.name for e in base.elements
            if any(e.name.startswith(f"winding.{p}.s") for p in PHASES)
            or e.name.startswith(("insulation.wf.", "insulation.wr."))]
    els: list[Element] = []
    # each of the n - 1 junction insulations carries 1/(n-1) of C and (n-1) R_ins
    ins = dict(r_ins=v["insulation.R_ins"] * (n - 1), loss="insulation_dielectric_loss" in eff,
               k_d=v["insulation.k_d"], tau_d=v["insulation.tau_d"])
    for p in PHASES:
        g = f"winding.{p}"
        nodes = [p] + [f"{p}_m{k}" for k in range(1, n)] + ["N"]
        for k in range(n):
            els += winding_section(
                f"{g}.s{k + 1}", nodes[k], nodes[k + 1], r=v[f"{g}.R_w"] / n,
                l_h=v[f"{g}.L_w"] / n, r_p=2 * v[f"{g}.R_p"] / n, c_s=n * v[f"{g}.C_s"] / 2,
                skin="winding_skin_effect" in eff, l_frac=v["winding.skin_l_frac"],
                rho=v["winding.skin_rho"], n_rungs=n_rungs)
        for k, node in enumerate(nodes[1:-1]):
            els += insulation(f"insulation.wf.{p}.{k + 1}", node, "F",
                              c=v[f"{g}.C_wf"] / (n - 1), **ins)  # type: ignore[arg-type]
            els += insulation(f"insulation.wr.{p}.{k + 1}", node, "SM",
                              c=v["insulation.C_wr"] / (n - 1), **ins)  # type: ignore[arg-type]
    keep = [e for e in base.elements if e.name not in set(drop)]
    return Circuit(elements=tuple(keep + els), title=base.title)
