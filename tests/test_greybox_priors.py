"""Physical priors (vfmodel.greybox.priors, contact, sizing) against hand-computed physics:
Hertz's circular contact, the Hamrock-Dowson exponents, Walther's viscosity line, the
cylindrical capacitor of the air gap, the film capacitance of the loaded contacts; the
negative log-prior's gradient; flagging."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vfmodel.core.machine_info import BearingInfo, MachineInfo, PriorOverride
from vfmodel.errors import InputError
from vfmodel.greybox.assembly import param_specs
from vfmodel.greybox.contact import (
    EPS0,
    central_film_thickness,
    hertz_contact,
    race_contacts,
    walther_viscosity,
)
from vfmodel.greybox.priors import (
    BOUNDARY_FILM_M,
    flag_implausible,
    neg_log_prior,
    parameter_priors,
    prior_residuals,
)

# a 40-kW machine with a 6210-like bearing, everything given
MACHINE = MachineInfo(rated_power_kw=40.0, stator_bore_m=0.2, stack_length_m=0.2,
                      air_gap_m=1e-3, slots=48, slot_opening_m=3e-3, wedge_thickness_m=2e-3)
BEARING = BearingInfo(balls=10, ball_diameter_m=12.7e-3, pitch_diameter_m=70e-3,
                      radial_load_n=200.0, lubricant_permittivity=2.2,
                      viscosity_40c_cst=100.0, viscosity_100c_cst=11.0,
                      pressure_viscosity_per_gpa=20.0, density_kg_m3=870.0,
                      temperature_c=80.0)


def test_hertz_circle_matches_textbook() -> None:
    """Two steel balls R 10 and 15 mm pressed with 5 N (Stachowiak & Batchelor, Engineering
    Tribology, Sec. 7.2 example): R' = 6 mm, E' = 2.308e11, exact a = (3 W R'/(2 E'))^(1/3)
    = 5.80e-5 m. Hamrock-Brewe's fits are within 4 % for a circle."""
    h = hertz_contact(5.0, 6e-3, 6e-3, 2.308e11)
    a_exact = (3 * 5.0 * 6e-3 / (2 * 2.308e11)) ** (1 / 3)
    assert a_exact == pytest.approx(5.80e-5, rel=2e-3)
    assert h.a == pytest.approx(a_exact, rel=0.04)
    assert h.b == pytest.approx(a_exact, rel=0.04)
    # elastic approach of a circle: delta = a^2 / R_1 with R_1 = R' (sphere on flat)
    assert h.delta == pytest.approx(a_exact**2 / 6e-3, rel=0.06)


def test_hamrock_dowson_exponents_and_value() -> None:
    """h_c ~ u^0.67 eta^0.67 Q^-0.067 and the formula's value typed out by hand."""
    args = dict(eta0=0.02, u=1.0, alpha=2e-8, q_n=100.0, r_x=5e-3, k=5.0, e_eff=2.3e11)
    h = central_film_thickness(**args)
    hand = 5e-3 * 2.69 * (0.02 * 1.0 / (2.3e11 * 5e-3)) ** 0.67 * (2e-8 * 2.3e11) ** 0.53 \
        * (100.0 / (2.3e11 * 25e-6)) ** -0.067 * (1 - 0.61 * math.exp(-0.73 * 5.0))
    assert h == pytest.approx(hand, rel=1e-12)
    assert 0.05e-6 < h < 1e-6  # an EHL film of tens to hundreds of nm
    assert central_film_thickness(**{**args, "u": 3.0}) / h == pytest.approx(
        3**0.67, rel=1e-12)
    assert central_film_thickness(**{**args, "q_n": 800.0}) / h == pytest.approx(
        8**-0.067, rel=1e-12)


def test_walther_line_through_its_two_points() -> None:
    assert walther_viscosity(100.0, 11.0, 40.0) == pytest.approx(100.0, rel=1e-9)
    assert walther_viscosity(100.0, 11.0, 100.0) == pytest.approx(11.0, rel=1e-9)
    nu80 = walther_viscosity(100.0, 11.0, 80.0)
    assert 11.0 < nu80 < 100.0
    # the log-log line interpolated by hand at 80 degC
    y = lambda nu: math.log10(math.log10(nu + 0.7))  # noqa: E731
    x = [math.log10(313.15), math.log10(373.15), math.log10(353.15)]
    y80 = y(100.0) + (y(11.0) - y(100.0)) * (x[2] - x[0]) / (x[1] - x[0])
    assert nu80 == pytest.approx(10 ** (10**y80) - 0.7, rel=1e-9)


def test_airgap_capacitance_is_the_cylindrical_capacitor() -> None:
    pri = parameter_priors(machine=MACHINE, bearing=BEARING)
    c = pri["airgap.C_rf"]
    hand = 2 * math.pi * 8.8541878128e-12 * 0.2 / math.log(0.1 / 0.099) \
        * (1 - 48 * 3e-3 / (math.pi * 0.2))
    assert c.kind == "lognormal" and c.median == pytest.approx(hand, rel=1e-9)
    # thin gap: the plate capacitor eps0 pi D l / g within 1 %
    assert c.median == pytest.approx(EPS0 * math.pi * 0.2 * 0.2 / 1e-3 * (1 - 0.2292), rel=0.01)
    assert c.gsd == pytest.approx(1.5)  # rating given: no size spread
    # winding-rotor: slot openings through wedge (eps 4) and gap, 1.5x for end windings
    wr = EPS0 * 48 * 0.2 * 3e-3 / (2e-3 / 4 + 1e-3) * 1.5 / 3
    assert pri["insulation.C_wr"].median == pytest.approx(wr, rel=1e-9)


def test_film_capacitance_from_hertz_area_and_film() -> None:
    """C_1 = n_loaded x (inner || outer in series), each eps0 eps_r pi a b / h_c."""
    pri = parameter_priors(machine=MACHINE, bearing=BEARING, speed_rpm=300.0)
    q = math.pi * 200.0 / 10  # mean load of the 5 balls of the load zone
    cin, cout = race_contacts(q, 12.7e-3, 70e-3)
    eta = 1e-6 * walther_viscosity(100.0, 11.0, 80.0) * 870.0
    w = 2 * math.pi * 300.0 / 60
    u = w * (0.07**2 - 0.0127**2) / (4 * 0.07)
    caps = [EPS0 * 2.2 * c.hertz.area / central_film_thickness(eta, u, 2e-8, q, c.r_x,
                                                                c.hertz.k)
            for c in (cin, cout)]
    hand = 5 * caps[0] * caps[1] / (caps[0] + caps[1])
    assert pri["lubricant.C_1"].median == pytest.approx(hand, rel=1e-9)
    assert 20e-12 < hand < 2e-9  # hundreds of pF for a 50-mm ball bearing


def test_film_capacitance_falls_as_speed_to_the_067() -> None:
    c = [parameter_priors(machine=MACHINE, bearing=BEARING, speed_rpm=s)["lubricant.C_1"]
         for s in (200.0, 400.0)]
    assert c[1].median / c[0].median == pytest.approx(2**-0.67, rel=1e-9)
    # standstill: the boundary layer, far thinner than any EHL film
    c0 = parameter_priors(machine=MACHINE, bearing=BEARING, speed_rpm=0.0)["lubricant.C_1"]
    assert "5.0 nm" in c0.basis and BOUNDARY_FILM_M == 5e-9
    assert c0.median > 5 * c[0].median


def test_every_parameter_has_a_prior_and_size_spreads_it() -> None:
    names = {s.name for s in param_specs()}
    free = parameter_priors()
    rated = parameter_priors(machine=MachineInfo(rated_power_kw=30.0))
    assert set(free) == names == set(rated)
    for n in names:
        assert free[n].lower < free[n].median < free[n].upper, n
    # without a rating the 3-300 kW spread widens the geometric priors
    for n in ("airgap.C_rf", "insulation.C_wr", "lubricant.C_1"):
        assert free[n].gsd > rated[n].gsd * 1.05, n


def test_neg_log_prior_gradient_and_residuals() -> None:
    pri = parameter_priors(machine=MACHINE, bearing=BEARING)
    # one log-normal at 2 sigma, one range inside, one range beyond its upper bound
    vals = {"airgap.C_rf": pri["airgap.C_rf"].median * 1.5**2,
            "insulation.k_d": 0.1, "winding.skin_rho": 40.0}
    nlp, grad = neg_log_prior(vals, pri)
    r, dr = prior_residuals(np.log(list(vals.values())), list(vals), pri)
    assert r[0] == pytest.approx(2.0, rel=1e-12) and r[1] == 0.0 and dr[1] == 0.0
    assert dr[0] == pytest.approx(1 / pri["airgap.C_rf"].sigma, rel=1e-12)
    s = pri["winding.skin_rho"].sigma
    assert r[2] == pytest.approx(math.log(2.0) / s, rel=1e-12)
    assert nlp == pytest.approx(0.5 * float(r @ r), rel=1e-12)
    for n, v in vals.items():
        e = 1e-6
        up, _ = neg_log_prior({**vals, n: v * math.exp(e)}, pri)
        dn, _ = neg_log_prior({**vals, n: v * math.exp(-e)}, pri)
        assert grad[n] == pytest.approx((up - dn) / (2 * e), rel=1e-5, abs=1e-9), n


def test_flags_what_is_far_outside() -> None:
    pri = parameter_priors(machine=MACHINE, bearing=BEARING, speed_rpm=0.0)
    c_wr = pri["insulation.C_wr"]
    vals = {"insulation.C_wr": c_wr.median / c_wr.gsd**3.5,     # 3.5 sigma below: flagged
            "airgap.C_rf": pri["airgap.C_rf"].median * 1.5**2.5,  # 2.5 sigma: not
            "lubricant.C_1": 0.8e-6}      # a standstill "film" of 0.8 uF is a short
    flags = {f.name: f for f in flag_implausible(vals, pri)}
    assert set(flags) == {"insulation.C_wr", "lubricant.C_1"}
    assert flags["insulation.C_wr"].z == pytest.approx(-3.5, rel=1e-9)
    assert flags["lubricant.C_1"].direction == "above" and flags["lubricant.C_1"].z > 4
    assert "sigma below" in flags["insulation.C_wr"].describe()


def test_overrides_replace_and_unknown_names_are_refused() -> None:
    ov = {"insulation.C_wr": PriorOverride(median=2e-10, gsd=2.0),
          "lubricant.R_1": PriorOverride(lower=1e3, upper=1e9)}
    pri = parameter_priors(overrides=ov)
    assert pri["insulation.C_wr"].median == 2e-10 and pri["insulation.C_wr"].source == "override"
    assert pri["lubricant.R_1"].kind == "range" and pri["lubricant.R_1"].upper == 1e9
    with pytest.raises(InputError, match=r"insulation\.C_xx"):
        parameter_priors(overrides={"insulation.C_xx": PriorOverride(median=1.0, gsd=2.0)})
