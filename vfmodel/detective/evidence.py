"""Implausible fitted values as evidence (issue 14, deliverable 2).

A network that lacks an effect bends the parameters it has to describe the data anyway; a
fitted value far outside its physical prior (:func:`vfmodel.greybox.priors.
flag_implausible`, more than :data:`N_SIGMA` geometric sigmas from the prior's median) is
therefore a clue to the missing physics. :data:`EXPLAINS` maps a parameter and the
direction of its excursion to the effects of the vocabulary that would let the network
keep a physical value there (why, per entry); :func:`implausible_evidence` lists, for a
fit, each flagged value with those effects and what the detective made of them (found,
rejected with its reason, already in the network, or not a candidate of this run). Every
effect of the vocabulary is a candidate of every round, so a mapped effect is tested like
any other; the mapping says which test answers the implausible value.

Parameters are matched by base name (a per-speed copy ``<name>@<s>rpm`` by ``<name>``,
with ``standstill`` distinguishing the base lubricant value: it acts at standstill only,
where a metallic contact would short it).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from vfmodel.greybox.priors import Prior, flag_implausible

__all__ = ["EXPLAINS", "N_SIGMA", "Explanation", "implausible_evidence"]

N_SIGMA = 3.0
"""Excursion (geometric sigmas of the prior) from which a value counts as implausible."""


@dataclass(frozen=True)
class Explanation:
    """``param`` (base name) ``direction`` ("above"/"below") its prior, at standstill only
    (``standstill`` True), rotating only (False) or both (None), is what a network without
    ``effect`` does to describe it; ``why`` says how."""

    param: str
    direction: str
    standstill: bool | None
    effect: str
    why: str


_SHORT = ("a metallic contact conducts at standstill; a network whose film must stay a "
          "capacitor describes the short as a film of huge capacitance or tiny resistance")
EXPLAINS: tuple[Explanation, ...] = (
    Explanation("lubricant.C_1", "above", True, "metallic_contact", _SHORT),
    Explanation("lubricant.R_1", "below", True, "metallic_contact", _SHORT),
    Explanation("lubricant.C_2", "above", True, "metallic_contact", _SHORT),
    Explanation("bearing.C_edge", "above", True, "metallic_contact", _SHORT),
    Explanation("insulation.C_wr", "below", None, "metallic_contact",
                "with the contact closed the rotor sits at frame potential at standstill; a "
                "network with a capacitive film at rest scales the rotor-side "
                "capacitances down instead"),
    Explanation("airgap.C_rf", "below", None, "metallic_contact",
                "as for insulation.C_wr: the rotor-side divider scaled down to mimic a "
                "shorted bearing"),
    Explanation("lubricant.C_1", "above", False, "hertzian_edge_capacitance",
                "the lubricant-filled gap around the Hertzian ellipses adds capacitance in "
                "parallel with the film; without it the film takes it"),
    Explanation("lubricant.C_1", "above", False, "lubricant_two_layer",
                "a thickener layer changes the film's apparent capacitance over the band"),
    Explanation("lubricant.C_1", "below", False, "lubricant_two_layer",
                "a second layer in series lowers the apparent capacitance of the film"),
    Explanation("lubricant.R_1", "below", False, "lubricant_dielectric_loss",
                "dielectric loss of the lubricant is a conductance rising with frequency; a "
                "film without it lowers its resistance to dissipate as much"),
    Explanation("bearing.C_edge", "above", False, "lubricant_two_layer",
                "a capacitance beside the film growing to carry what a second layer would"),
)
"""The effect that explains each kind of implausible value (module docstring)."""


def _base(name: str) -> tuple[str, bool]:
    """Base name and whether the value acts at standstill (no ``@<s>rpm`` tag)."""
    base, sep, _ = name.partition("@")
    return base, not sep


def _status(effect: str, in_network: frozenset[str], found: Mapping[str, str],
            rejected: Mapping[str, str]) -> str:
    if effect in found:
        return f"found at {found[effect]}"
    if effect in rejected:
        return f"rejected: {rejected[effect]}"
    if effect in in_network:
        return "already in the network"
    return "not a candidate of this run"


def implausible_evidence(values: Mapping[str, float], priors: Mapping[str, Prior],
                         in_network: frozenset[str], found: Mapping[str, str],
                         rejected: Mapping[str, str], *, n_sigma: float = N_SIGMA
                         ) -> list[dict[str, Any]]:
    """Every fitted value more than ``n_sigma`` from its prior (largest excursion first)
    with the effects that explain it (:data:`EXPLAINS`) and their outcome.

    ``values``: fitted parameters by name (per-speed copies included); ``priors``: their
    priors (a name without one is not judged); ``in_network``: effects the fitted network
    has; ``found``: effect -> location of the detective's findings; ``rejected``: effect ->
    reason of its rejection.
    """
    out = []
    for f in flag_implausible(values, priors, n_sigma=n_sigma):
        base, standstill = _base(f.name)
        expl = [e for e in EXPLAINS if e.param == base and e.direction == f.direction
                and e.standstill in (None, standstill)]
        out.append({"parameter": f.name, "value": f.value, "z_sigma": f.z,
                    "prior_median": f.prior.median, "prior_gsd": f.prior.gsd,
                    "prior_basis": f.prior.basis, "message": f.describe(),
                    "explained_by": [{"effect": e.effect, "why": e.why,
                                      "outcome": _status(e.effect, in_network, found,
                                                         rejected)} for e in expl]})
    return out

