"""Geometry and lubricant data of a dataset: the ``[machine]``, ``[bearing]`` and
``[priors]`` tables of ``dataset.toml`` (all optional; see docs/dataset-priors.md).

Every field is optional (``None`` = not given); the physical priors of the grey-box model
(:mod:`vfmodel.greybox.priors`) fill what is missing with defaults for the machine size
range of this project. Lengths in metres, loads in newtons, temperatures in degC.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

__all__ = ["BearingInfo", "MachineInfo", "PriorOverride", "field_names"]


@dataclass(frozen=True)
class MachineInfo:
    """``[machine]``: rating and the geometry the rotor-side capacitances depend on.

    Attributes
    ----------
    rated_power_kw, rated_speed_rpm, rated_voltage_v : float
        Rating (voltage: line-to-line RMS); without a bore and stack length they size the
        machine (output equation).
    pole_pairs : int
    stator_bore_m, stack_length_m, air_gap_m : float
        Stator bore diameter, core length, mechanical air gap (stator bore to the rotor's
        outer conducting surface: magnets or rotor iron).
    slots : int
        Stator slots.
    slot_opening_m : float
        Width of a slot opening at the bore.
    slot_depth_m, slot_width_m : float
        Depth and mean width of a slot (the liner's area is ``(2 depth + width) l``).
    slot_insulation_m : float
        Effective distance between the conductors and the slot wall (liner plus the
        resin/air gap to the outer wires).
    insulation_permittivity : float
        Relative permittivity of slot liner and impregnation.
    wedge_thickness_m : float
        Distance from the top conductors to the bore through the slot wedge.
    shaft_diameter_m, shaft_length_m : float
        Shaft diameter and its length between the bearings.
    """

    rated_power_kw: float | None = None
    rated_speed_rpm: float | None = None
    rated_voltage_v: float | None = None
    pole_pairs: int | None = None
    stator_bore_m: float | None = None
    stack_length_m: float | None = None
    air_gap_m: float | None = None
    slots: int | None = None
    slot_opening_m: float | None = None
    slot_depth_m: float | None = None
    slot_width_m: float | None = None
    slot_insulation_m: float | None = None
    insulation_permittivity: float | None = None
    wedge_thickness_m: float | None = None
    shaft_diameter_m: float | None = None
    shaft_length_m: float | None = None


BEARING_TYPES = ("deep_groove_ball", "angular_contact_ball")
"""Bearing types whose contacts the priors compute (ball on raceway, Hertzian ellipse)."""


@dataclass(frozen=True)
class BearingInfo:
    """``[bearing]``: one bearing (both are taken alike) and its lubricant.

    Attributes
    ----------
    type : str
        One of :data:`BEARING_TYPES`.
    balls : int
    ball_diameter_m, pitch_diameter_m : float
    width_m : float
        Bearing width.
    radial_clearance_m : float
        Internal radial clearance (gap of the unloaded balls).
    contact_angle_deg : float
        Nominal contact angle (0 for a deep-groove bearing under radial load).
    inner_conformity, outer_conformity : float
        Groove radius / ball diameter (0.50-0.56; typically 0.52 and 0.53).
    radial_load_n, axial_load_n : float
        Load on this bearing (axial: e.g. a spring preload; 0 allowed).
    roughness_m : float
        Composite rms roughness of ball and raceway (film parameter ``lambda = h / sigma``).
    lubricant_permittivity : float
        Relative permittivity of the base oil (2-3.5).
    lubricant_resistivity_ohm_m : float
        Resistivity of the lubricant in the film.
    viscosity_40c_cst, viscosity_100c_cst : float
        Kinematic viscosity of the base oil at 40 and 100 degC (mm^2/s).
    pressure_viscosity_per_gpa : float
        Pressure-viscosity coefficient alpha (1/GPa).
    density_kg_m3 : float
        Base-oil density.
    temperature_c : float
        Bearing temperature (default: the dataset's ``temperature_c``).
    """

    type: str | None = None
    balls: int | None = None
    ball_diameter_m: float | None = None
    pitch_diameter_m: float | None = None
    width_m: float | None = None
    radial_clearance_m: float | None = None
    contact_angle_deg: float | None = None
    inner_conformity: float | None = None
    outer_conformity: float | None = None
    radial_load_n: float | None = None
    axial_load_n: float | None = None
    roughness_m: float | None = None
    lubricant_permittivity: float | None = None
    lubricant_resistivity_ohm_m: float | None = None
    viscosity_40c_cst: float | None = None
    viscosity_100c_cst: float | None = None
    pressure_viscosity_per_gpa: float | None = None
    density_kg_m3: float | None = None
    temperature_c: float | None = None


@dataclass(frozen=True)
class PriorOverride:
    """``[priors]`` entry of one parameter: a log-normal (``median`` and geometric standard
    deviation ``gsd`` > 1) or a log-uniform range (``lower`` < ``upper``)."""

    median: float | None = None
    gsd: float | None = None
    lower: float | None = None
    upper: float | None = None

    @property
    def kind(self) -> str:
        """``"lognormal"`` or ``"range"``."""
        return "lognormal" if self.median is not None else "range"


def field_names(cls: type) -> tuple[str, ...]:
    """Names of the fields of one of the dataclasses above (the table's allowed keys)."""
    return tuple(f.name for f in fields(cls))
