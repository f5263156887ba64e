"""Machine and bearing geometry for the physical priors: the values a dataset gives in its
``[machine]`` / ``[bearing]`` tables, the rest sized from the rated power.

Sizing (what is not given): torque ``T = P / w`` from the output equation with tangential
stress ``sigma_t = 20 kPa`` and aspect ratio ``l / D = 1`` (``T = sigma_t pi D^2 l / 2``);
air gap ``g = 0.18 mm + 0.006 mm (P / W)^0.4`` (empirical, machines with more than one pole
pair); slot pitch 12 mm; shaft diameter ``0.25 D``; a 62-series deep-groove ball bearing
on the shaft (ball ``0.25 d``, pitch diameter ``1.4 d``, ``Z = pi d_e / (1.75 d_ball)``
balls, width ``1.6 d_ball``) carrying half the rotor weight. Lubricant: ISO VG 100 mineral
base oil (100 / 11 mm^2/s at 40 / 100 degC, 870 kg/m^3, alpha 20 /GPa, eps_r 2.2).
Each default is an assumption stated here; the priors' spreads cover it.

References
----------
J. Pyrhonen, T. Jokinen, V. Hrabovcova, "Design of Rotating Electrical Machines", Wiley,
2008, Sec. 6.1-6.2 (tangential stress, air gap).
T. A. Harris, M. N. Kotzalas, "Rolling Bearing Analysis", 5th ed., CRC Press, 2006
(deep-groove bearing proportions, load zone).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vfmodel.core.machine_info import BearingInfo, MachineInfo

__all__ = ["DEFAULT_TEMPERATURE_C", "POWER_RANGE_KW", "Geometry", "resolve_geometry"]

POWER_RANGE_KW = (3.0, 300.0)
"""Rated powers this project's machines span; without a rating the priors cover it."""
DEFAULT_TEMPERATURE_C = 60.0
"""Bearing temperature when neither ``[bearing] temperature_c`` nor ``temperature_c``."""
TANGENTIAL_STRESS_PA = 20e3
STEEL_DENSITY = 7800.0


@dataclass(frozen=True)
class Geometry:
    """Every quantity the priors use, resolved to a number (SI units, degC)."""

    power_w: float
    speed_rpm: float
    voltage_v: float
    pole_pairs: int
    bore: float
    length: float
    gap: float
    slots: int
    slot_opening: float
    slot_depth: float
    slot_width: float
    slot_insulation: float
    eps_insulation: float
    wedge: float
    shaft_d: float
    shaft_length: float
    balls: int
    ball_d: float
    pitch_d: float
    bearing_width: float
    clearance: float
    contact_angle_rad: float
    f_inner: float
    f_outer: float
    radial_load: float
    axial_load: float
    roughness: float
    eps_lub: float
    rho_lub: float
    nu40: float
    nu100: float
    alpha: float
    density: float
    temperature_c: float

    @property
    def torque(self) -> float:
        return self.power_w / (2 * math.pi * self.speed_rpm / 60)


def _pick(given: float | None, default: float) -> float:
    return float(default if given is None else given)


def resolve_geometry(machine: MachineInfo | None, bearing: BearingInfo | None,
                     temperature_c: float | None, power_kw: float) -> Geometry:
    """The geometry of ``machine`` / ``bearing`` with every missing value sized from
    ``power_kw`` (used when ``machine.rated_power_kw`` is not given)."""
    m = machine or MachineInfo()
    b = bearing or BearingInfo()
    p_w = 1e3 * _pick(m.rated_power_kw, power_kw)
    n = _pick(m.rated_speed_rpm, 1500.0)
    torque = p_w / (2 * math.pi * n / 60)
    # T = sigma_t pi D^2 l / 2 with l = D unless one of them is given
    d2l = 2 * torque / (math.pi * TANGENTIAL_STRESS_PA)
    if m.stator_bore_m is not None and m.stack_length_m is not None:
        bore, length = m.stator_bore_m, m.stack_length_m
    elif m.stator_bore_m is not None:
        bore, length = m.stator_bore_m, d2l / m.stator_bore_m**2
    elif m.stack_length_m is not None:
        bore, length = math.sqrt(d2l / m.stack_length_m), m.stack_length_m
    else:
        bore = length = d2l ** (1 / 3)
    gap = _pick(m.air_gap_m, 1e-3 * (0.18 + 0.006 * p_w**0.4))
    slots = int(m.slots) if m.slots is not None else max(12, 6 * round(math.pi * bore / 0.012 / 6))
    shaft_d = _pick(m.shaft_diameter_m, 0.25 * bore)
    ball_d = _pick(b.ball_diameter_m, 0.25 * shaft_d)
    pitch_d = _pick(b.pitch_diameter_m, 1.4 * shaft_d)
    balls = int(b.balls) if b.balls is not None else max(6, round(math.pi * pitch_d
                                                                   / (1.75 * ball_d)))
    rotor_mass = STEEL_DENSITY * math.pi * (bore / 2 - gap) ** 2 * length
    temp = b.temperature_c if b.temperature_c is not None else (
        temperature_c if temperature_c is not None else DEFAULT_TEMPERATURE_C)
    return Geometry(
        power_w=p_w, speed_rpm=n, voltage_v=_pick(m.rated_voltage_v, 400.0),
        pole_pairs=int(m.pole_pairs) if m.pole_pairs is not None else 2,
        bore=bore, length=length, gap=gap, slots=slots,
        slot_opening=_pick(m.slot_opening_m, 2.5e-3),
        slot_depth=_pick(m.slot_depth_m, 0.12 * bore),
        slot_width=_pick(m.slot_width_m, 0.5 * math.pi * bore / slots),
        slot_insulation=_pick(m.slot_insulation_m, 1.5e-3),
        eps_insulation=_pick(m.insulation_permittivity, 3.5),
        wedge=_pick(m.wedge_thickness_m, 2e-3),
        shaft_d=shaft_d, shaft_length=_pick(m.shaft_length_m, length + bore),
        balls=balls, ball_d=ball_d, pitch_d=pitch_d,
        bearing_width=_pick(b.width_m, 1.6 * ball_d),
        clearance=_pick(b.radial_clearance_m, 15e-6),
        contact_angle_rad=math.radians(_pick(b.contact_angle_deg, 0.0)),
        f_inner=_pick(b.inner_conformity, 0.52), f_outer=_pick(b.outer_conformity, 0.53),
        radial_load=_pick(b.radial_load_n, 0.5 * 9.81 * rotor_mass),
        axial_load=_pick(b.axial_load_n, 0.0),
        roughness=_pick(b.roughness_m, 0.1e-6),
        eps_lub=_pick(b.lubricant_permittivity, 2.2),
        rho_lub=_pick(b.lubricant_resistivity_ohm_m, 1e10),
        nu40=_pick(b.viscosity_40c_cst, 100.0), nu100=_pick(b.viscosity_100c_cst, 11.0),
        alpha=1e-9 * _pick(b.pressure_viscosity_per_gpa, 20.0),
        density=_pick(b.density_kg_m3, 870.0), temperature_c=float(temp))
