"""Physical priors of the grey-box parameters (issue 14): what physics says before any fit.

Every parameter of :func:`vfmodel.greybox.assembly.param_specs` gets a :class:`Prior`,
either **log-normal** (``median`` and geometric standard deviation ``gsd``: ``ln(value)``
is normal with mean ``ln(median)`` and standard deviation ``ln(gsd)``) or a **log-uniform
range** ``[lower, upper]`` where physics gives bounds but no preferred value. The numbers
come from the formulas below applied to the dataset's ``[machine]`` / ``[bearing]`` data
(:mod:`vfmodel.greybox.sizing` fills what is missing); without a rated power the prior is
evaluated at 3, 30 and 300 kW (:data:`~vfmodel.greybox.sizing.POWER_RANGE_KW`) and the
log-spread of that range is added as ``ln(q_300 / q_3) / 4`` (the range taken as +-2
sigma) to the physics spread; ranges take the union. ``[priors]`` entries replace any
prior. Priors are physics defaults, never values of a bench.

Formulas (per phase where the parameter is per phase; ``eps0`` vacuum permittivity,
``mu0`` vacuum permeability, ``D`` bore, ``l`` stack length, ``g`` air gap, ``N_s``
slots, ``b_so`` slot opening):

- ``airgap.C_rf``: cylindrical capacitor over the air gap, less the slot openings:
  ``2 pi eps0 l / ln(r / (r - g)) (1 - N_s b_so / (pi D))``, gsd 1.5 (fringing, ends,
  eccentricity) [Busse 1997].
- ``insulation.C_wr``: winding to rotor through the slot openings, wedge (``eps_r`` 4,
  thickness ``h_w``) and air gap in series, plus the end windings (taken as half as much
  again): ``eps0 N_s l b_so / (h_w / 4 + g) * 1.5 / 3``, gsd 2.5 [Busse 1997].
- ``winding.*.C_wf``: slot liner as a plate capacitor over the slot wall
  ``N_s l (2 h_s + w_s)`` at the effective distance ``d_ins`` (liner plus the voids between
  round wires; default 1.5 mm, an assumption) with ``eps_r`` 3.5, per phase, gsd 3.
- ``lubricant.C_1``: the film of the loaded contacts, ``eps0 eps_r pi a b / h`` per
  contact (Hertzian ellipse ``a, b``; central EHL film ``h ~ speed^0.67`` by Hamrock-Dowson,
  at least a boundary layer of 5 nm; at standstill that layer), inner and outer contact in
  series, the loaded balls in parallel; gsd 3 (load, starvation, formula).
- ``lubricant.R_1``: ``rho h / (pi a b)`` likewise (film time constant ``rho eps``). In
  full film (``lambda = h / sigma >= 3``, Tallian) log-normal around it with gsd 10 (grease
  resistivity); in mixed or boundary lubrication asperity contacts bridge the film and the
  prior is the range from 1 ohm to ten times the full-film value.
- ``bearing.C_edge``: lubricant-filled gap around the loaded contacts outside the ellipse
  (:func:`~vfmodel.greybox.contact.outside_hertz_capacitance`: from the film plus the
  elastic approach to 1 % of the ball diameter), gsd 3.
- ``bearing.C_air``: the rings as a coaxial capacitor over the bearing width plus the
  unloaded balls across the radial clearance, gsd 3.
- ``ball.R_dc`` (the path through balls and races, which at standstill carries the
  metallic contact) and ``bearing.R_h``: range from Holm's constriction resistance of the
  loaded contacts (clean metal) to 10 ohm (boundary and oxide layers).
- ``shaft.L_1/L_2``: half the shaft as a coaxial conductor inside the frame,
  ``mu0 l_s / (2 pi) ln(0.8 D / r_shaft)`` (cf. :data:`~vfmodel.greybox.assembly.PATH_L_MAX`),
  ``shaft.L_int`` ``mu0 l_s / (8 pi)``, ``shaft.R_dc`` ``rho_steel l_s / (pi r^2)`` (gsd
  10: with a ladder of few rungs R_dc also carries part of the skin-effect resistance);
  ball path and frame alike (coaxial sections), gsd 2.5-3.
- winding ``R_w`` (2 % copper loss at rated current), ``L_w`` (leakage 0.15 p.u.), ``R_p``
  (twice the wave impedance ``sqrt(L_w / C_wf)``), ``C_s``, ``C_t``, ``fixture.L``: order-of-
  magnitude priors with gsd 3-5; dimensionless ladder ratios, loss fractions and relaxation
  times: ranges.

Note (measured 2026-11-24): the reference paper's divider bearing capacitance, 18.1 nF at
100 rpm (its Table IV), is about 100 times the Hertzian film of a bearing of a 40-kW
machine (a 6210-size bearing at 100 rpm and 80 degC: film 44 nm, ``C_1`` ~ 0.15 nF). The
paper-like ``lubricant.C_1 = 20 nF`` of ``default_params()`` (and the benches built on it)
is therefore flagged, 3.9 sigma above the prior without geometry. The lumped ``C_1`` of
such records absorbs more than the loaded contacts' film (grease-filled gaps, the races'
whole surroundings); whether that calls for a wider film prior or another reading of
``C_1`` is open.

References
----------
D. Busse, J. Erdman, R. J. Kerkman, D. Schlegel, G. Skibinski, "System electrical
parameters and their effects on bearing currents", IEEE Trans. Ind. Appl. 33(2), 577-584,
1997 (the capacitances C_wf, C_wr, C_rf, C_b of the divider and their geometry).
A. Muetze, A. Binder, "Practical rules for assessment of inverter-induced bearing currents
in inverter-fed AC motors up to 500 kW", IEEE Trans. Ind. Electron. 54(3), 1614ff, 2007
(how the capacitances scale over 1-500 kW).
T. E. Tallian, "On competing failure modes in rolling contact", ASLE Trans. 10(4),
418-439, 1967 (film parameter lambda).
IEEE Std 43-2013 (insulation resistance: at least 5 Mohm for random-wound windings).
Contact physics and its references: :mod:`vfmodel.greybox.contact`; sizing:
:mod:`vfmodel.greybox.sizing`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vfmodel.core.dataset import Dataset
from vfmodel.core.machine_info import BearingInfo, MachineInfo, PriorOverride
from vfmodel.errors import InputError
from vfmodel.greybox.assembly import PATH_L_MAX, param_specs
from vfmodel.greybox.contact import (
    EPS0,
    central_film_thickness,
    constriction_resistance,
    entrainment_speed,
    film_capacitance,
    outside_hertz_capacitance,
    race_contacts,
    walther_viscosity,
)
from vfmodel.greybox.params import ParamSet
from vfmodel.greybox.sizing import POWER_RANGE_KW, Geometry, resolve_geometry

__all__ = [
    "BOUNDARY_FILM_M",
    "Implausible",
    "Prior",
    "check_overrides",
    "flag_implausible",
    "neg_log_prior",
    "parameter_priors",
    "prior_residuals",
    "prior_rows",
]

ArrF = NDArray[np.float64]
MU0 = 4e-7 * math.pi
RHO_STEEL = 2.5e-7
"""Resistivity of bearing and shaft steel, ohm m (about)."""
BOUNDARY_FILM_M = 5e-9
"""Thinnest film: an adsorbed boundary layer (nm scale); the film at standstill."""
MENISCUS = 0.01
"""The lubricant around a contact fills the gap out to this fraction of the ball diameter."""
FULL_FILM_LAMBDA = 3.0
CONTACT_R_MAX = 10.0
SQRT12 = math.sqrt(12.0)


@dataclass(frozen=True)
class Prior:
    """Prior of one parameter.

    Attributes
    ----------
    name : str
    kind : "lognormal" or "range"
    median, gsd : float
        Log-normal: median and geometric standard deviation (> 1). Range: the geometric
        centre ``sqrt(lower upper)`` and ``exp(ln(upper/lower) / sqrt(12))`` (the standard
        deviation of ``ln(value)`` of the log-uniform law).
    lower, upper : float
        Range: its bounds. Log-normal: ``median / gsd^3`` and ``median gsd^3``.
    source : "physics" or "override"
    basis : str
        The formula and inputs it came from.
    """

    name: str
    kind: Literal["lognormal", "range"]
    median: float
    gsd: float
    lower: float
    upper: float
    source: str
    basis: str

    @property
    def sigma(self) -> float:
        """Standard deviation of ``ln(value)``."""
        return math.log(self.gsd)

    def z(self, value: float) -> float:
        """Signed distance ``(ln value - ln median) / sigma``; inside a range ``|z| <=
        sqrt(3)``."""
        return (math.log(value) - math.log(self.median)) / self.sigma

    def as_dict(self) -> dict[str, object]:
        return {"kind": self.kind, "median": self.median, "gsd": self.gsd,
                "lower": self.lower, "upper": self.upper, "source": self.source,
                "basis": self.basis}


def _lognormal(name: str, median: float, gsd: float, basis: str,
               source: str = "physics") -> Prior:
    return Prior(name, "lognormal", median, gsd, median / gsd**3, median * gsd**3, source,
                 basis)


def _range(name: str, lo: float, hi: float, basis: str, source: str = "physics") -> Prior:
    return Prior(name, "range", math.sqrt(lo * hi), math.exp(math.log(hi / lo) / SQRT12),
                 lo, hi, source, basis)


# ------------------------------------------------------------------------ bearing film
@dataclass(frozen=True)
class _Film:
    n_loaded: int
    c_film: float
    r_film: float
    c_edge: float
    c_air: float
    r_contact: float
    lam: float
    h_m: float


def _bearing_film(geo: Geometry, speed_rpm: float) -> _Film:
    """Film, edge and air capacitance, film and constriction resistance of one bearing."""
    z = geo.balls
    if geo.axial_load > 0:  # every ball carries the axial load, at >= 10 deg
        beta = max(geo.contact_angle_rad, math.radians(10.0))
        n_loaded, q = z, geo.axial_load / (z * math.sin(beta)) + geo.radial_load / z
    else:  # Stribeck: Q_max = 5 F_r / Z; the mean over the Z/2 balls of the zone ~ pi F_r / Z
        beta = geo.contact_angle_rad
        n_loaded, q = max(1, z // 2), math.pi * geo.radial_load / z
    contacts = race_contacts(q, geo.ball_d, geo.pitch_d, geo.f_inner, geo.f_outer, beta)
    u = entrainment_speed(speed_rpm, geo.pitch_d, geo.ball_d, beta)
    eta = 1e-6 * walther_viscosity(geo.nu40, geo.nu100, geo.temperature_c) * geo.density
    hs = [max(central_film_thickness(eta, u, geo.alpha, q, c.r_x, c.hertz.k),
              BOUNDARY_FILM_M) for c in contacts]
    eps = geo.eps_lub

    def series(a: float, b: float) -> float:
        return a * b / (a + b)

    c_in, c_out = (film_capacitance(c.hertz.area, h, eps) for c, h in zip(contacts, hs,
                                                                           strict=True))
    r_film = sum(geo.rho_lub * h / c.hertz.area for c, h in zip(contacts, hs, strict=True))
    h_out = MENISCUS * geo.ball_d
    e_in, e_out = (outside_hertz_capacitance(c, h + c.hertz.delta, h_out, eps)
                   for c, h in zip(contacts, hs, strict=True))
    g_in, g_out = (outside_hertz_capacitance(c, geo.clearance, h_out, eps) for c in contacts)
    r_i = geo.pitch_d / 2 - 0.35 * geo.ball_d
    r_o = geo.pitch_d / 2 + 0.35 * geo.ball_d
    annulus = 2 * math.pi * EPS0 * eps * geo.bearing_width / math.log(r_o / r_i)
    r_c = sum(constriction_resistance(RHO_STEEL, c.hertz.a, c.hertz.b) for c in contacts)
    return _Film(n_loaded, n_loaded * series(c_in, c_out), r_film / n_loaded,
                 n_loaded * series(e_in, e_out),
                 annulus + (z - n_loaded) * series(g_in, g_out), r_c / n_loaded,
                 min(hs) / geo.roughness, min(hs))


# ------------------------------------------------------------------------ the table
def _physics(geo: Geometry, speed_rpm: float) -> dict[str, Prior]:
    """Every parameter's prior for one resolved geometry."""
    out: dict[str, Prior] = {}

    def ln(name: str, median: float, gsd: float, basis: str) -> None:
        out[name] = _lognormal(name, median, gsd, basis)

    def rg(name: str, lo: float, hi: float, basis: str) -> None:
        out[name] = _range(name, lo, hi, basis)

    d, l_s, g = geo.bore, geo.length, geo.gap
    opening = geo.slots * geo.slot_opening / (math.pi * d)
    c_rf = 2 * math.pi * EPS0 * l_s / math.log(d / 2 / (d / 2 - g)) * (1 - opening)
    c_wr = EPS0 * geo.slots * l_s * geo.slot_opening / (geo.wedge / 4.0 + g) * 1.5 / 3
    c_wf = EPS0 * geo.eps_insulation * geo.slots * l_s * (2 * geo.slot_depth
                                                          + geo.slot_width) \
        / geo.slot_insulation / 3
    v_ph = geo.voltage_v / math.sqrt(3)
    i_ph = geo.power_w / (3 * v_ph * 0.85)
    r_w = 0.02 * geo.power_w / (3 * i_ph**2)
    l_w = 0.15 * (v_ph / i_ph) / (2 * math.pi * geo.pole_pairs * geo.speed_rpm / 60)
    size = f"D {d * 1e3:.0f} mm, l {l_s * 1e3:.0f} mm, g {g * 1e3:.2f} mm, {geo.slots} slots"
    for p in ("U", "V", "W"):
        w = f"winding.{p}"
        ln(f"{w}.R_w", r_w, 3.0, "2 % copper loss at rated current")
        ln(f"{w}.L_w", l_w, 3.0, "leakage inductance 0.15 p.u.")
        ln(f"{w}.R_p", 2 * math.sqrt(l_w / c_wf), 5.0, "twice the wave impedance "
           "sqrt(L_w / C_wf)")
        ln(f"{w}.C_s", 20e-12, 5.0, "series chain of turn-to-turn capacitances (order of "
           "magnitude)")
        ln(f"{w}.C_t", 100e-12, 3.0, "leads and terminal box to the housing (~1 m at "
           "~100 pF/m)")
        ln(f"{w}.C_wf", c_wf, 3.0, f"slot liner plate capacitor, {size}")
        rg(f"{w}.C_taper", 0.2, 5.0, "line-end to neutral-end share of the insulation "
           "capacitance: coils of unequal slot and end-winding length, reinforced line-end "
           "insulation (a few times either way)")
    ln("winding.C_pp", 20e-12, 5.0, "end-winding and terminal-box coupling of adjacent "
       "phases' line-end coils (order of magnitude)")
    rg("winding.skin_l_frac", 0.01, 0.5, "internal share of the winding inductance")
    rg("winding.skin_rho", 1.5, 20.0, "RL-ladder ratio")
    rg("insulation.R_ins", 5e6, 1e13, "IEEE Std 43 minimum to clean modern insulation")
    rg("insulation.k_d", 0.01, 0.5, "dielectric increment of polymer insulation")
    rg("insulation.tau_d", 1e-9, 1e-2, "Debye relaxation time anywhere in the band")
    ln("insulation.C_wr", c_wr, 2.5, f"slot openings and end windings, {size}")
    ln("airgap.C_rf", c_rf, 1.5, f"cylindrical capacitor over the air gap, {size}")
    frame_len = l_s + d
    # the ladders' few rungs make R_dc carry part of the skin-effect resistance too: loose
    ln("frame.R_dc", 1e-4, 10.0, "housing path, steel or aluminium (order of magnitude)")
    ln("frame.L_ext", MU0 / (2 * math.pi) * frame_len * math.log(2.0), 3.0,
       "housing as a coaxial return path")
    ln("frame.L_int", MU0 / (8 * math.pi) * frame_len, 3.0, "internal inductance")
    rg("frame.rho", 1.5, 20.0, "RL-ladder ratio")
    half = geo.shaft_length / 2
    r_sh = geo.shaft_d / 2
    ln("shaft.R_dc", RHO_STEEL * half / (math.pi * r_sh**2), 10.0, "half the shaft, steel")
    l_coax = min(MU0 / (2 * math.pi) * half * math.log(0.8 * d / r_sh), PATH_L_MAX)
    for k in ("1", "2"):
        ln(f"shaft.L_{k}", l_coax, 2.5, "half the shaft as a coaxial conductor in the frame")
    ln("shaft.L_int", MU0 / (8 * math.pi) * half, 3.0, "internal inductance of half the shaft")
    rg("shaft.rho", 1.5, 20.0, "RL-ladder ratio")
    film = _bearing_film(geo, speed_rpm)
    ln("ball.L_ext", MU0 / (2 * math.pi) * geo.bearing_width * math.log(0.8 * d / r_sh),
       3.0, "bearing width as a coaxial section shaft-frame")
    ln("ball.L_int", MU0 / (8 * math.pi) * geo.ball_d, 3.0, "internal inductance of a ball")
    rg("ball.rho", 1.5, 20.0, "RL-ladder ratio")
    rg("ball.R_dc", film.r_contact, CONTACT_R_MAX,
       "Holm constriction of the loaded contacts to boundary/oxide layers")
    rg("bearing.R_h", film.r_contact, CONTACT_R_MAX,
       "Holm constriction of the loaded contacts to boundary/oxide layers")
    brg = (f"{geo.balls} balls of {geo.ball_d * 1e3:.1f} mm, {film.n_loaded} loaded, "
           f"film {film.h_m * 1e9:.1f} nm at {speed_rpm:g} rpm, {geo.temperature_c:g} degC")
    ln("bearing.C_air", film.c_air, 3.0, "rings coaxial over the width, unloaded balls "
       "across the clearance")
    ln("bearing.C_edge", film.c_edge, 3.0, f"gap around the Hertzian ellipses, {brg}")
    ln("lubricant.C_1", film.c_film, 3.0, f"Hertzian film, Hamrock-Dowson, {brg}")
    if film.lam >= FULL_FILM_LAMBDA:
        ln("lubricant.R_1", film.r_film, 10.0,
           f"full film, rho {geo.rho_lub:.3g} ohm m, lambda {film.lam:.2g}")
    else:
        rg("lubricant.R_1", 1.0, max(10 * film.r_film, 10.0),
           f"mixed/boundary lubrication (lambda {film.lam:.2g}): 1 ohm to 10x full film")
    rg("lubricant.C_2", 0.5 * film.c_film, 60 * film.c_film,
       "thickener layer: share 5-60 % of the film, permittivity 1-3x the oil's")
    rg("lubricant.R_2", 1e-2, max(10 * film.r_film, 10.0),
       "thickener layer: properties not known beyond the film's bound")
    rg("lubricant.k_d", 0.01, 1.0, "dielectric increment of the lubricant")
    rg("lubricant.tau_d", 1e-9, 1e-2, "relaxation time anywhere in the band")
    ln("fixture.L", 50e-9, 3.0, "measurement leads of ~5 cm at ~1 uH/m")
    return out


def _combine(mid: Prior, lo: Prior, hi: Prior) -> Prior:
    """Widen ``mid`` by the spread between the smallest and largest machine."""
    if mid.kind == "range":
        return _range(mid.name, min(mid.lower, lo.lower, hi.lower),
                      max(mid.upper, lo.upper, hi.upper), mid.basis + " (3-300 kW)")
    s_size = abs(math.log(hi.median / lo.median)) / 4
    s = math.hypot(mid.sigma, s_size)
    return _lognormal(mid.name, mid.median, math.exp(s), mid.basis + " (3-300 kW)")


def parameter_priors(dataset: Dataset | None = None, speed_rpm: float = 100.0, *,
                     machine: MachineInfo | None = None, bearing: BearingInfo | None = None,
                     temperature_c: float | None = None,
                     overrides: Mapping[str, PriorOverride] | None = None
                     ) -> dict[str, Prior]:
    """Prior of every grey-box parameter (the names of ``param_specs()``).

    The speed-dependent parameters (lubricant film, Hertzian contact) are those at
    ``speed_rpm`` (0: boundary lubrication at standstill). ``machine``, ``bearing``,
    ``temperature_c`` and ``overrides`` default to the dataset's.
    """
    if not (math.isfinite(speed_rpm) and speed_rpm >= 0):
        raise InputError("speed_rpm must be finite and >= 0", found=repr(speed_rpm))
    if dataset is not None:
        machine = machine or dataset.machine
        bearing = bearing or dataset.bearing
        temperature_c = dataset.temperature_c if temperature_c is None else temperature_c
        overrides = dataset.prior_overrides if overrides is None else overrides
        check_overrides(dataset)
    rated = machine is not None and machine.rated_power_kw is not None
    p_lo, p_hi = POWER_RANGE_KW
    p_mid = math.sqrt(p_lo * p_hi)
    mid = _physics(resolve_geometry(machine, bearing, temperature_c, p_mid), speed_rpm)
    if not rated:
        lo = _physics(resolve_geometry(machine, bearing, temperature_c, p_lo), speed_rpm)
        hi = _physics(resolve_geometry(machine, bearing, temperature_c, p_hi), speed_rpm)
        mid = {k: _combine(v, lo[k], hi[k]) for k, v in mid.items()}
    for name, ov in (overrides or {}).items():
        if name not in mid:
            raise InputError("unknown parameter in prior overrides", place=name,
                             expected="a name of param_specs()")
        if ov.median is not None and ov.gsd is not None:
            mid[name] = _lognormal(name, ov.median, ov.gsd, "[priors] override", "override")
        elif ov.lower is not None and ov.upper is not None:
            mid[name] = _range(name, ov.lower, ov.upper, "[priors] override", "override")
    names = tuple(s.name for s in param_specs())
    assert set(names) == set(mid), sorted(set(names) ^ set(mid))
    return {n: mid[n] for n in names}


def check_overrides(dataset: Dataset) -> None:
    """InputError naming ``dataset.toml`` and the key for a ``[priors]`` name that is not a
    grey-box parameter."""
    names = {s.name for s in param_specs()}
    for name in dataset.prior_overrides:
        if name not in names:
            src = str(dataset.root / "dataset.toml") if dataset.root else dataset.name
            raise InputError("unknown parameter", source=src, place=f"[priors] {name!r}",
                             expected="a grey-box parameter name such as insulation.C_wr, "
                                      "lubricant.C_1 (see vfmodel.greybox.assembly."
                                      "param_specs)")


# ------------------------------------------------------------------------ use in fits
def prior_residuals(x_log: ArrayLike, names: Sequence[str], priors: Mapping[str, Prior]
                    ) -> tuple[ArrF, ArrF]:
    """Whitened prior residuals ``r`` of ``x = ln(value)`` and ``dr/dx`` (diagonal).

    Log-normal: ``r = (x - ln median) / sigma``. Range: 0 inside, ``(x - ln bound) /
    sigma_r`` beyond a bound (``sigma_r`` = :attr:`Prior.sigma`). Stacked below the data
    residuals of a least-squares fit they give the maximum a posteriori estimate;
    ``0.5 sum r^2`` is the negative log-prior density of ``x`` up to a constant.
    """
    x = np.asarray(x_log, dtype=float).ravel()
    if x.size != len(names):
        raise InputError("x_log and names differ in length",
                         found=f"{x.size} values, {len(names)} names")
    r = np.zeros(x.size)
    dr = np.zeros(x.size)
    for i, n in enumerate(names):
        p = priors[n]
        s = p.sigma
        if p.kind == "lognormal":
            r[i], dr[i] = (x[i] - math.log(p.median)) / s, 1.0 / s
        elif x[i] < math.log(p.lower):
            r[i], dr[i] = (x[i] - math.log(p.lower)) / s, 1.0 / s
        elif x[i] > math.log(p.upper):
            r[i], dr[i] = (x[i] - math.log(p.upper)) / s, 1.0 / s
    return r, dr


def prior_rows(x_log: ArrayLike, names: Sequence[str], priors: Mapping[str, Prior]
               ) -> tuple[ArrF, ArrF]:
    """The rows a maximum a posteriori fit of ``x = ln p`` (over ``names``) stacks below its
    data residuals: :func:`prior_residuals` of the names that have a prior in ``priors``
    (in their order; the others give no row) and their Jacobian ``(rows, len(names))``."""
    x = np.asarray(x_log, dtype=float).ravel()
    idx = np.array([i for i, n in enumerate(names) if n in priors], dtype=int)
    jm = np.zeros((idx.size, x.size))
    if not idx.size:
        return np.zeros(0), jm
    r, dr = prior_residuals(x[idx], [names[i] for i in idx], priors)
    jm[np.arange(idx.size), idx] = dr
    return r, jm


def neg_log_prior(values: Mapping[str, float] | ParamSet, priors: Mapping[str, Prior]
                  ) -> tuple[float, dict[str, float]]:
    """``(-ln p, d(-ln p)/d ln(value) by name)`` over the names of ``values`` that have a
    prior: ``0.5 sum r^2`` of :func:`prior_residuals` (density of ``ln(value)``, without
    its normalising constant)."""
    vals = values.as_dict() if isinstance(values, ParamSet) else dict(values)
    names = [n for n in vals if n in priors]
    x = np.log(np.array([vals[n] for n in names], dtype=float))
    r, dr = prior_residuals(x, names, priors)
    return float(0.5 * r @ r), {n: float(ri * di) for n, ri, di in zip(names, r, dr,
                                                                         strict=True)}


@dataclass(frozen=True)
class Implausible:
    """A value far from its prior: ``z`` sigmas (of ``ln(value)``) from the median."""

    name: str
    value: float
    z: float
    prior: Prior

    @property
    def direction(self) -> str:
        return "above" if self.z > 0 else "below"

    def describe(self) -> str:
        return (f"{self.name} = {self.value:.3g} is {abs(self.z):.1f} sigma {self.direction} "
                f"its prior (median {self.prior.median:.3g}, {self.prior.basis})")


def flag_implausible(values: Mapping[str, float] | ParamSet,
                     priors: Mapping[str, Prior] | None = None, *, n_sigma: float = 3.0
                     ) -> list[Implausible]:
    """Parameters of ``values`` more than ``n_sigma`` geometric sigmas from their prior's
    median (:meth:`Prior.z`; a range's values stay within ``sqrt(3)``), largest first.

    ``priors`` default to :func:`parameter_priors` without a dataset at 100 rpm.
    """
    pri = parameter_priors() if priors is None else priors
    vals = values.as_dict() if isinstance(values, ParamSet) else dict(values)
    out = []
    for n, v in vals.items():
        if n in pri and v > 0:
            z = pri[n].z(float(v))
            if abs(z) > n_sigma:
                out.append(Implausible(n, float(v), z, pri[n]))
    return sorted(out, key=lambda f: -abs(f.z))
