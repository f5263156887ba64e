"""Every string-valued choice of the public API, as ``Literal`` aliases.

The runtime list of allowed values is ``typing.get_args(Alias)``; validate with
:func:`check_choice` so that error messages name the argument and the allowed set.
"""

from __future__ import annotations

from typing import Any, Literal, get_args

Kind = Literal["Z", "Y", "S", "H"]
"""Representation of a frequency response: impedance, admittance, scattering, transfer."""

ImmittanceKind = Literal["Z", "Y"]

Weighting = Literal[
    "auto", "relative", "uniform", "inv_abs", "inv_sqrt_abs", "inverse", "inverse-sqrt"
]
"""Vector-fitting weights: "relative" 1/||H(f)||_F per frequency (relative accuracy per
point), "uniform" 1, "inv_abs"/"inverse" 1/|H_ij|, "inv_sqrt_abs"/"inverse-sqrt"
1/sqrt|H_ij|; "auto" = "relative" for Z, Y, H data spanning more than a decade, else
"uniform" (a user array is also accepted)."""

DcMode = Literal["enforce", "fit"]
"""0 Hz sample: matched exactly by D ("enforce") or fitted like any sample ("fit")."""

PoleSpacing = Literal["log", "lin"]

Topology = Literal["U-Frame", "V-Frame", "W-Frame", "U-V", "V-W", "W-U"]
"""Impedance measurement topologies of CONTRACT section 2 (the reference paper's six)."""

FurtherTopology = Literal["Shaft-Frame"]
"""Further impedance topologies of CONTRACT section 2a: ``Shaft-Frame`` between the NDE
shaft end and the frame with the terminals U, V, W open."""

Effect = Literal[
    "winding_skin_effect",
    "insulation_dielectric_loss",
    "frame_skin_effect",
    "shaft_skin_effect",
    "ball_skin_effect",
    "lubricant_dielectric_loss",
    "lubricant_two_layer",
    "hertzian_edge_capacitance",
    "metallic_contact",
    "fixture_inductance",
    "endwinding_capacitance",
]
"""Effect vocabulary of the discrepancy detective (CONTRACT section 7)."""

BearingState = Literal["standstill", "rotating"]
"""Bearing lubrication state of the grey-box network: metallic contact closed or open."""

SectionsBy = Literal["spectra", "records"]
"""How ``reproduce`` chooses the winding-section count: by the impedance spectra alone or
by the rotating records among the spectra's choice and its neighbours
(:mod:`vfmodel.greybox.section_choice`)."""

KINDS: tuple[str, ...] = get_args(Kind)
TOPOLOGIES: tuple[str, ...] = get_args(Topology)
"""The six paper topologies (what ``Dataset.impedance`` holds and the pipeline iterates)."""
FURTHER_TOPOLOGIES: tuple[str, ...] = get_args(FurtherTopology)
"""Topologies beyond the paper's (``Dataset.further_impedance``, ``impedance_at_speed``)."""
ALL_TOPOLOGIES: tuple[str, ...] = TOPOLOGIES + FURTHER_TOPOLOGIES
EFFECTS: tuple[str, ...] = get_args(Effect)


def check_choice(name: str, value: Any, alias: Any) -> Any:
    """Return ``value`` if it is in ``get_args(alias)``; else InputError naming ``name``."""
    allowed = get_args(alias)
    if value not in allowed:
        from vfmodel.errors import InputError

        raise InputError(
            f"{name}: got {value!r}; expected one of {', '.join(repr(a) for a in allowed)}"
        )
    return value
