"""The film's DC resistance is bounded from below only when its discharge may be slower than
the record resolves (greybox.bearing.film_time_constant, greybox.lsq.lower_bound_only;
issue 19: on independent benches the oil film relaxes in 2.7-13 ms against 1 ms records)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from vfmodel.circuit.netlist import Circuit
from vfmodel.greybox.assembly import default_params
from vfmodel.greybox.bearing import film_time_constant
from vfmodel.greybox.lsq import lower_bound_only
from vfmodel.greybox.substructures import bearing

Z95 = 1.959964


def test_time_constant_is_the_slowest_layer() -> None:
    p = default_params().with_values({"lubricant.R_1": 2e5, "lubricant.C_1": 5e-9,
                                      "lubricant.k_d": 0.5, "lubricant.R_2": 1e3,
                                      "lubricant.C_2": 2e-6})
    # one layer: R_1 C_1 = 1 ms; with the loss branch C_1 (1 + k_d) at low frequency
    assert film_time_constant(p, set()) == pytest.approx(1e-3, rel=1e-12)
    assert film_time_constant(p, {"lubricant_dielectric_loss"}) == pytest.approx(
        1.5e-3, rel=1e-12)
    # the second layer (R_2 C_2 = 2 ms) is slower
    assert film_time_constant(p, {"lubricant_two_layer"}) == pytest.approx(2e-3, rel=1e-12)


def test_dc_resistance_beyond_the_corner_is_invisible_in_band() -> None:
    # the premise, on the bearing's own network: a film whose corner lies below the record's
    # resolution 1/T (tau = 5 ms, T = 1 ms) has, from 1/T up, an admittance that differs by
    # at most 1 / (2 pi f tau) ~ 3 % relative when R grows tenfold (C fixed), while one
    # with tau = 0.05 ms changes by tens of percent: the first bounds R from below only
    p = default_params()
    f = np.geomspace(1e3, 1e5, 21)

    def y(r: float, c: float) -> np.ndarray:
        els = bearing("b", "S", "0", c_air=1e-15, ball_r=p["ball.R_dc"],
                      ball_l_ext=p["ball.L_ext"], ball_l_int=p["ball.L_int"],
                      ball_rho=p["ball.rho"], ball_skin=False, r_h=p["bearing.R_h"],
                      r_1=r, c_1=c, two_layer=False, r_2=1.0, c_2=1.0, lub_loss=False,
                      k_d=0.0, tau_d=1e-9, edge=False, c_edge=1e-12, metallic=False,
                      closed=False)
        z = Circuit(elements=tuple(els)).port_impedance(f, [("S", "0")])[:, 0, 0]
        return np.asarray(1.0 / z)

    c = 10e-9
    slow = np.max(np.abs(y(5e6, c) / y(5e5, c) - 1))   # tau 50 ms -> 5 ms
    fast = np.max(np.abs(y(5e4, c) / y(5e3, c) - 1))   # tau 0.5 ms -> 0.05 ms
    assert slow < 1 / (2 * np.pi * 1e3 * 5e-3) + 1e-3
    assert fast > 0.5


def _iv(value: float, sd: float) -> dict[str, float | None]:
    return {"value": value, "lo": value * math.exp(-Z95 * sd),
            "hi": value * math.exp(Z95 * sd), "std_log": sd}


def test_lower_bound_only_when_the_corner_may_leave_the_band() -> None:
    r = _iv(1e5, 0.3)
    t_rec = 1e-3
    # tau's upper end 0.1 ms: 2 pi 0.1 ms = 0.63 ms <= 1 ms, resolved: two-sided, unchanged
    fast = lower_bound_only(r, _iv(0.1e-3 * math.exp(-Z95 * 0.1), 0.1), t_rec)
    assert fast["bound"] == "two-sided"
    assert fast["lo"] == r["lo"] and fast["hi"] == r["hi"]
    assert fast["record_s"] == t_rec
    # tau's upper end 0.2 ms: 2 pi 0.2 ms = 1.26 ms > 1 ms: the lower bound alone
    slow = lower_bound_only(r, _iv(0.2e-3 * math.exp(-Z95 * 0.1), 0.1), t_rec)
    assert slow["bound"] == "lower"
    assert slow["lo"] == r["lo"] and slow["hi"] is None
    assert slow["time_constant_s"]["hi"] == pytest.approx(0.2e-3, rel=1e-12)
    # tau not bounded by the data: lower bound too; the input is not changed
    free = lower_bound_only(r, {"value": 1e-4, "lo": None, "hi": None, "std_log": None},
                            t_rec)
    assert free["bound"] == "lower" and free["hi"] is None
    assert r["hi"] is not None
    json.dumps([fast, slow, free], allow_nan=False)


def test_report_shows_a_lower_bound() -> None:
    from vfmodel.report.html import _interval

    text, flag = _interval({"value": 2.4e4, "lo": 122.0, "hi": None, "std_log": 2.7,
                            "bound": "lower"}, "Ω", ["bearing", "100", "lubricant_interval",
                                                     "r_ohm"])
    assert "[≥ " in text and "122" in text and "…" not in text
    assert "bounded below only" in flag
    both, _ = _interval(_iv(1e5, 0.3), "Ω", ["r"])
    assert "…" in both and "≥" not in both
    # without a bound the data give none (lower_bound_only with tau unbounded and no lo)
    none, flag = _interval({"value": 1e5, "lo": None, "hi": None, "std_log": None,
                            "bound": "lower"}, "Ω", ["r"])
    assert "unbounded" in none and "not determined" in flag
