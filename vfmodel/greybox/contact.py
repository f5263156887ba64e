"""Ball-raceway contact physics of a rolling bearing: Hertzian ellipse, EHL film thickness,
lubricant viscosity, and the capacitances and resistance of the lubricated contacts.

Pure formulas (SI units) used by :mod:`vfmodel.greybox.priors`. Conventions of Hamrock
and Dowson: ``x`` is the rolling direction, ``R_x`` and ``R_y`` the effective radii of
curvature in and across it, ``1/R = 1/R_x + 1/R_y``, ``E' = 2 / ((1-nu_a^2)/E_a +
(1-nu_b^2)/E_b)`` (steel on steel: 228 GPa), ``Q`` the normal load of one contact.

References
----------
B. J. Hamrock, D. E. Brewe, "Simplified solution for stresses and deformations",
J. Lubr. Technol. 105(2), 171-177, 1983 -- curve fits of the elliptic integrals and of the
ellipticity used by :func:`hertz_contact`.
B. J. Hamrock, D. Dowson, "Isothermal elastohydrodynamic lubrication of point contacts,
Part III -- Fully flooded results", J. Lubr. Technol. 99(2), 264-275, 1977.
doi:10.1115/1.3453074 -- central film thickness of :func:`central_film_thickness`.
T. A. Harris, M. N. Kotzalas, "Rolling Bearing Analysis", 5th ed., CRC Press, 2006 --
raceway curvatures, mean entrainment speed, Stribeck load distribution.
ASTM D341 -- viscosity-temperature chart equation (Walther), :func:`walther_viscosity`.
R. Holm, "Electric Contacts", 4th ed., Springer, 1967 -- constriction resistance
``rho / (2 a)`` of a circular spot of radius ``a`` (:func:`constriction_resistance`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = [
    "EPS0",
    "E_STEEL_EFF",
    "Contact",
    "HertzContact",
    "central_film_thickness",
    "constriction_resistance",
    "entrainment_speed",
    "film_capacitance",
    "hertz_contact",
    "outside_hertz_capacitance",
    "race_contacts",
    "walther_viscosity",
]

EPS0 = 8.8541878128e-12
"""Vacuum permittivity, F/m."""
E_STEEL_EFF = 2.0 / (2 * (1 - 0.3**2) / 210e9)
"""``E'`` of bearing steel on bearing steel (E = 210 GPa, nu = 0.3): 230.8 GPa."""


@dataclass(frozen=True)
class HertzContact:
    """Dry Hertzian contact: semi-axes ``a`` (across rolling, the longer) and ``b`` (along
    rolling), ellipticity ``k = a / b``, elastic approach ``delta`` (m), area ``pi a b``."""

    a: float
    b: float
    k: float
    delta: float

    @property
    def area(self) -> float:
        return math.pi * self.a * self.b


def hertz_contact(q_n: float, r_x: float, r_y: float, e_eff: float = E_STEEL_EFF
                  ) -> HertzContact:
    """Hertzian ellipse of a point contact with load ``q_n`` (N), Hamrock-Brewe fits.

    ``k = 1.0339 (R_y/R_x)^0.636``, ``E = 1.0003 + 0.5968 R_x/R_y``,
    ``F = 1.5277 + 0.6023 ln(R_y/R_x)``; ``a = (6 k^2 E Q R / (pi E'))^(1/3)``,
    ``b = (6 E Q R / (pi k E'))^(1/3)``, ``delta = F (9/(2 E R) (Q/(pi k E'))^2)^(1/3)``
    (the fits hold for ``R_y >= R_x``; a circle comes out within 4 % of the exact Hertz
    radius ``(3 Q R_1 / (2 E'))^(1/3)``, ``R_1`` = sphere radius on a flat).
    """
    if not (q_n > 0 and r_x > 0 and r_y > 0 and e_eff > 0):
        raise ValueError("hertz_contact: load, radii and modulus must be > 0")
    ratio = r_y / r_x
    k = 1.0339 * ratio**0.636
    ell_e = 1.0003 + 0.5968 / ratio
    ell_f = 1.5277 + 0.6023 * math.log(ratio)
    r = 1.0 / (1.0 / r_x + 1.0 / r_y)
    a = (6 * k * k * ell_e * q_n * r / (math.pi * e_eff)) ** (1 / 3)
    b = (6 * ell_e * q_n * r / (math.pi * k * e_eff)) ** (1 / 3)
    delta = ell_f * (9 / (2 * ell_e * r) * (q_n / (math.pi * k * e_eff)) ** 2) ** (1 / 3)
    return HertzContact(a, b, k, delta)


def central_film_thickness(eta0: float, u: float, alpha: float, q_n: float, r_x: float,
                           k: float, e_eff: float = E_STEEL_EFF) -> float:
    """Central EHL film thickness (m), Hamrock-Dowson (1977), fully flooded, isothermal.

    ``h_c / R_x = 2.69 U^0.67 G^0.53 W^-0.067 (1 - 0.61 exp(-0.73 k))`` with ``U = eta0 u /
    (E' R_x)``, ``G = alpha E'``, ``W = Q / (E' R_x^2)``; ``eta0`` dynamic viscosity (Pa s)
    at the inlet, ``u`` mean entrainment speed (m/s), ``alpha`` pressure-viscosity
    coefficient (1/Pa). The film grows with speed as ``u^0.67``.
    """
    if u <= 0:
        return 0.0
    big_u = eta0 * u / (e_eff * r_x)
    big_g = alpha * e_eff
    big_w = q_n / (e_eff * r_x * r_x)
    return r_x * 2.69 * big_u**0.67 * big_g**0.53 * big_w**-0.067 \
        * (1 - 0.61 * math.exp(-0.73 * k))


def walther_viscosity(nu40_cst: float, nu100_cst: float, temp_c: float) -> float:
    """Kinematic viscosity (mm^2/s) at ``temp_c`` from the values at 40 and 100 degC:
    ASTM D341, ``log10 log10(nu + 0.7) = A - B log10(T / K)``."""
    t1, t2, t = 313.15, 373.15, temp_c + 273.15
    y1 = math.log10(math.log10(nu40_cst + 0.7))
    y2 = math.log10(math.log10(nu100_cst + 0.7))
    b = (y1 - y2) / (math.log10(t2) - math.log10(t1))
    y = y1 - b * (math.log10(t) - math.log10(t1))
    return float(10 ** (10**y) - 0.7)


def entrainment_speed(speed_rpm: float, pitch_d: float, ball_d: float,
                      contact_angle_rad: float = 0.0) -> float:
    """Mean entrainment (rolling) speed ``u = |w_i - w_o| (d_e^2 - d^2 cos^2 b) / (4 d_e)``
    of both contacts with the inner ring turning at ``speed_rpm`` and the outer ring fixed."""
    w = 2 * math.pi * abs(speed_rpm) / 60
    c = math.cos(contact_angle_rad)
    return w * (pitch_d**2 - (ball_d * c) ** 2) / (4 * pitch_d)


@dataclass(frozen=True)
class Contact:
    """One ball-raceway contact: radii ``r_x``, ``r_y`` (m) and its Hertzian ellipse."""

    r_x: float
    r_y: float
    hertz: HertzContact


def race_contacts(q_n: float, ball_d: float, pitch_d: float, f_inner: float = 0.52,
                  f_outer: float = 0.53, contact_angle_rad: float = 0.0,
                  e_eff: float = E_STEEL_EFF) -> tuple[Contact, Contact]:
    """Inner and outer contact of a ball of diameter ``ball_d`` on the pitch diameter
    ``pitch_d`` loaded with ``q_n``; ``f`` = groove radius / ball diameter.

    ``R_x = d (d_e -+ d cos b) / (2 d_e)`` (inner -, outer +), ``R_y = f d / (2 f - 1)``.
    """
    c = ball_d * math.cos(contact_angle_rad)
    out = []
    for sign, f in ((-1.0, f_inner), (1.0, f_outer)):
        r_x = ball_d * (pitch_d + sign * c) / (2 * pitch_d)
        r_y = f * ball_d / (2 * f - 1)
        out.append(Contact(r_x, r_y, hertz_contact(q_n, r_x, r_y, e_eff)))
    return out[0], out[1]


def film_capacitance(area: float, h: float, eps_r: float) -> float:
    """Plate capacitor ``eps0 eps_r A / h`` of a film of thickness ``h`` over ``area``."""
    return EPS0 * eps_r * area / h


def outside_hertz_capacitance(c: Contact, h_inner: float, h_outer: float,
                              eps_r: float) -> float:
    """Capacitance of the lubricant-filled gap around one contact, outside its ellipse.

    The undeformed gap ``g = h + x^2/(2 R_x) + y^2/(2 R_y)``; with ``x = sqrt(R_x) r cos t``,
    ``y = sqrt(R_y) r sin t`` the area element is ``sqrt(R_x R_y) r dr dt`` and
    ``int eps/g dA = 2 pi eps sqrt(R_x R_y) ln(g_out / g_in)``: here from the gap at the
    edge of the ellipse ``h_inner`` (film plus elastic approach) out to the gap
    ``h_outer`` where the lubricant meniscus ends.
    """
    if not h_outer > h_inner > 0:
        return 0.0
    return EPS0 * eps_r * 2 * math.pi * math.sqrt(c.r_x * c.r_y) * math.log(h_outer / h_inner)


def constriction_resistance(rho_ohm_m: float, a: float, b: float) -> float:
    """Holm's constriction resistance of a clean metallic spot, both sides: ``rho / (2 a_e)``
    with the equivalent radius ``a_e = sqrt(a b)`` of the ellipse."""
    return rho_ohm_m / (2 * math.sqrt(a * b))
