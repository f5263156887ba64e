"""Identifiability from the Fisher information and the ranking of further measurements
(vfmodel.detective.identifiability, vfmodel.detective.recommend), on small problems with
analytic answers: a linear model, a parameter without sensitivity, and a Shaft-Frame
measurement that separates the metallic contact by construction."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import pytest
from numpy.typing import NDArray

from vfmodel.detective.fit import FitResult
from vfmodel.detective.identifiability import (
    IDENTIFIED_STD_LOG,
    classify,
    effect_identifiability,
    fisher_std,
    grey_box_prior_sigma,
    identifiability,
)
from vfmodel.detective.problem import Candidate, Channel
from vfmodel.detective.recommend import (
    WIDE,
    WIDE_F_HI_HZ,
    Comparison,
    Net,
    recommend,
    separation,
    wide_grid,
)
from vfmodel.greybox.assembly import default_params
from vfmodel.greybox.effects import PAPER_EFFECTS
from vfmodel.greybox.identify import bearing_state
from vfmodel.greybox.network import NetSpec
from vfmodel.greybox.params import ParamSet, ParamSpec

# r = (A x - y) / sigma: J = A / sigma, J^T J = 100 [[3, 3], [3, 5]], inverse
# [[5, -3], [-3, 3]] / 600 -> std sqrt(5/600), sqrt(3/600); a prior of sigma 0.05 on x_1
# adds 400: F = [[300, 300], [300, 900]], det 1.8e5 -> std sqrt(900/1.8e5), sqrt(300/1.8e5)
_A = np.array([[1.0, 0.0], [1.0, 1.0], [1.0, 2.0]])
_J = _A / 0.1


def test_fisher_std_of_a_linear_model_is_the_analytic_one() -> None:
    np.testing.assert_allclose(fisher_std(_J), [math.sqrt(5 / 600), math.sqrt(3 / 600)],
                               rtol=1e-12)
    np.testing.assert_allclose(fisher_std(_J, [None, 0.05]),
                               [math.sqrt(900 / 1.8e5), math.sqrt(300 / 1.8e5)], rtol=1e-12)


def test_a_parameter_without_sensitivity() -> None:
    """Column of zeros: infinite std from the data; the prior alone then sets it."""
    j = np.column_stack([_J[:, 0], np.zeros(3)])
    sd = fisher_std(j)
    assert sd[0] == math.sqrt(1 / 300) and math.isinf(sd[1])
    assert fisher_std(j, [None, 0.5])[1] == 0.5
    ident = identifiability(j, ("a", "b"), {"b": 0.5})
    assert ident.status == ("identifiable", "prior-only")
    # a prior wider than the bound does not make it identifiable; no prior neither
    assert identifiability(j, ("a", "b"), {"b": 2.0}).status[1] == "not-identifiable"
    assert identifiability(j, ("a", "b")).status[1] == "not-identifiable"
    assert classify(0.99, 0.5) == "identifiable" and IDENTIFIED_STD_LOG == 1.0


def _fit(names: Sequence[str], chi2: float) -> FitResult:
    specs = [ParamSpec(n, 1.0, 1e-3, 1e3, "g", "", "") for n in names]
    return FitResult((), ParamSet.from_specs(specs), tuple(names), np.zeros(3), chi2, 3,
                     {}, np.eye(len(names)))


def test_effect_classes_from_its_trial() -> None:
    cand = Candidate("lubricant_dielectric_loss", "bearing.lubricant",
                     (ParamSpec("b", 1.0, 1e-3, 1e3, "effect", "", ""),))
    fit = _fit(("a", "b"), 1.0)
    j = np.column_stack([_J[:, 0], np.zeros(3)])
    e = effect_identifiability(cand, fit, j, -0.2)
    assert e.status == "not-identifiable" and "do not tell" in e.reason
    assert e.undetermined == ("b",)
    assert effect_identifiability(cand, fit, j, -0.2, {"b": 0.3}).status == "prior-only"
    assert effect_identifiability(cand, fit, _J, -40.0).status == "identifiable"
    # another effect explains the data as well: not identifiable whatever the std
    e = effect_identifiability(cand, fit, _J, -40.0, alternatives=("x at y",))
    assert e.status == "not-identifiable" and "x at y" in e.reason
    # a switch without parameters: seen or not by Delta chi2 alone
    sw = Candidate("metallic_contact", "bearing.contact")
    assert effect_identifiability(sw, fit, _J, -30.0).status == "identifiable"
    assert effect_identifiability(sw, fit, _J, -0.5).status == "not-identifiable"
    # a switch is no fitted parameter: seen from SWITCH_SEEN_CHI2 = 10, not from 1
    assert effect_identifiability(sw, fit, _J, -5.0).status == "not-identifiable"
    assert effect_identifiability(sw, fit, _J, -10.5).status == "identifiable"


def test_prior_sigma_of_per_speed_copies() -> None:
    """``lubricant.C_1@100rpm`` takes the 100-rpm prior (log-normal, gsd 3 widened by the
    3-300 kW spread), a plain name its standstill one; unknown names are left out."""
    s = grey_box_prior_sigma(["lubricant.C_1@100rpm", "airgap.C_rf", "x.y"])
    assert set(s) == {"lubricant.C_1@100rpm", "airgap.C_rf"}
    assert s["lubricant.C_1@100rpm"] >= math.log(3.0)


def test_separation_of_a_constant_relative_difference() -> None:
    """1 % on 100 points at sigma 0.5 %: 100 * (0.01 / 0.005)^2 = 400."""
    assert math.isclose(separation(np.full(100, 0.01 + 0j), 0.005), 400.0, rel_tol=1e-12)


@dataclass
class _Stub:
    """The parts of a PMSM family recommend() uses, on the paper's network."""

    channels: tuple[Channel, ...]
    preps: tuple[object, ...] = ()

    def spec(self, applied: Sequence[Candidate]) -> NetSpec:
        return NetSpec(frozenset(PAPER_EFFECTS - {"metallic_contact"})
                       | {c.effect for c in applied})

    def at_speed(self, params: ParamSet, rpm: float) -> ParamSet:
        return params

    def state(self, rpm: float, applied: Sequence[Candidate]) -> str:
        return bearing_state(rpm, self.spec(applied).effects)

    def bearing_terms(self) -> tuple[object, ...]:
        return ()


def test_recommendation_that_separates_by_construction_ranks_first() -> None:
    """The metallic contact closes the bearing at standstill: the shaft-to-frame impedance
    at 0 rpm sees it (decisive); the fixture inductance is not in that path, so it
    separates nothing (0 up to rounding) and ranks last."""
    f = np.geomspace(1e3, 1e7, 41)
    fam = _Stub((Channel("impedance:U-Frame", f, np.ones(41, complex), np.full(41, 0.005)),))
    p = default_params()
    mc = Candidate("metallic_contact", "bearing.contact")
    fx = Candidate("fixture_inductance", "fixture")
    cmps = [Comparison(("fixture_inductance",), Net((fx,), p), Net((), p), 1),
            Comparison(("metallic_contact",), Net((mc,), p), Net((), p), 0)]
    recs = recommend(fam, cmps)
    # the fixture inductance, not told on the spectra's band, is also offered the wide band
    # (to 100 MHz); the contact, told there decisively, is not
    assert [(r.measurement, r.speed_rpm) for r in recs] == [("impedance:Shaft-Frame", 0.0)] * 3
    assert recs[0].separates == ("metallic_contact",) and recs[0].decisive
    assert recs[0].expected_delta_chi2 > 1e4 and recs[0].band_hz == (1e3, 1e7)
    fix = sorted(recs[1:], key=lambda r: r.n_points)      # (both 0 up to rounding)
    assert [r.band_hz for r in fix] == [(1e3, 1e7), (1e3, 1e8)]
    for r in fix:
        assert r.separates == ("fixture_inductance",)
        assert r.expected_delta_chi2 < 1e-12 and not r.decisive   # rounding only
    # 41 points on 4 decades: the wide band keeps 10 points per decade
    assert fix[1].n_points == 51 and fix[1].as_json()["band_hz"] == [1e3, 1e8]
    # a measurement the dataset holds is not recommended
    assert recommend(fam, cmps, have={("impedance:Shaft-Frame", 0.0), (WIDE, 0.0)}) == []
    # the spectra's band held: the wide band is offered for both (the contact is no longer
    # told there by a recommendation of its own)
    assert [r.band_hz for r in recommend(fam, cmps, have={("impedance:Shaft-Frame", 0.0)})] \
        == [(1e3, 1e8)] * 2


def test_wide_grid_continues_the_spectra_grid() -> None:
    """The wide band starts on the spectra's grid and keeps its density up to 100 MHz; a
    grid that already reaches half of that gets none."""
    f = np.geomspace(1e3, 1e7, 201)
    w = wide_grid(f)
    assert w is not None and w.size == 251 and w[-1] == WIDE_F_HI_HZ
    np.testing.assert_allclose(w[:201], f, rtol=1e-12)
    assert wide_grid(np.geomspace(1e3, 6e7, 101)) is None


def test_a_refit_worse_than_the_network_without_is_not_assessed() -> None:
    """Nested networks: Delta chi2 > 0 beyond k means the refit stopped short."""
    cand = Candidate("winding_skin_effect", "R1",
                     (ParamSpec("b", 1.0, 1e-3, 1e3, "effect", "", ""),))
    e = effect_identifiability(cand, _fit(("a", "b"), 1.0), _J, +35.0)
    assert e.status == "not-identifiable" and "worse" in e.reason


def test_shaft_frame_sensitivity_matches_differences_and_spread_is_the_quadratic_form() -> None:
    """``d ln Z_SF / d ln p`` (adjoint) against central differences of the impedance, and
    the network spread of one parameter of variance c: ``c sum |g|^2 / sigma^2``."""
    from vfmodel.detective.recommend import _dlnz_dlnp, _shaft_frame, network_spread

    f = np.geomspace(1e3, 1e7, 21)
    fam = _Stub((Channel("impedance:U-Frame", f, np.ones(21, complex), np.full(21, 0.005)),))
    p = default_params()
    names = ("lubricant.C_1", "ball.R_dc", "airgap.C_rf")
    g = _dlnz_dlnp(fam, Net((), p), names, 0.0, f)
    h = 1e-3    # central differences: error h^2 ~ 1e-6 of the largest value (a smaller
    for j, n in enumerate(names):   # step meets the solver's rounding, 5e-6 at 1e-5)
        zp = _shaft_frame(fam, Net((), p.with_values({n: p[n] * math.exp(h)})), 0.0, f)
        zm = _shaft_frame(fam, Net((), p.with_values({n: p[n] * math.exp(-h)})), 0.0, f)
        fd = np.log(zp / zm) / (2 * h)
        np.testing.assert_allclose(g[:, j], fd, rtol=0, atol=1e-5 * float(np.max(np.abs(fd))))
    cov = np.diag([0.04, 0.0, 0.0])
    s = network_spread(fam, Net((), p), names, cov, 0.0, f, 0.005)
    assert math.isclose(s, 0.04 * float(np.sum(np.abs(g[:, 0]) ** 2)) / 0.005**2, rel_tol=1e-10)
    assert math.isinf(network_spread(fam, Net((), p), names, np.diag([np.inf, 0, 0]), 0.0,
                                     f, 0.005))


def test_report_names_the_first_decisive_measurement() -> None:
    from vfmodel.report.diagnose_html import diagnose_html

    doc: dict[str, Any] = {"model": "m", "sentence": "s", "mismatch_found": True, "findings": [],
           "identifiability": {
               "effects": {"lubricant_two_layer": "not-identifiable"},
               "parameters": {"a": "identifiable", "b": "prior-only"},
               "parameter_std_log": {"a": {"data": 0.1, "with_prior": 0.1, "prior": None},
                                     "b": {"data": None, "with_prior": 0.5, "prior": 0.5}},
               "effect_details": {"lubricant_two_layer at bearing.lubricant": {
                   "reason": "its parameters are not determined"}},
               "definition": "d"},
           "recommendations": [{"measurement": "impedance:Shaft-Frame", "speed_rpm": 300.0,
                                "separates": ["lubricant_two_layer"],
                                "expected_delta_chi2": 2860.0, "decisive": True,
                                "network_spread_delta_chi2": None}]}
    html = diagnose_html(doc, [])
    assert "Identifiability of the effects" in html and "Recommended measurements" in html
    assert "1 identifiable, 1 only through their prior, 0 not identifiable" in html
    assert "measure <b>impedance:Shaft-Frame</b> at 300" in html
    # decided at the size bound: the sentence gives that separation and says so
    doc["recommendations"][0].update(expected_delta_chi2=0.47, ranked_delta_chi2=1259.0,
                                     size_bound_share=0.73, ranked_size="bound",
                                     expected_delta_chi2_after_refit_at_bound=1259.0)
    html = diagnose_html(doc, [])
    assert "(expected Δχ² 1259 for the largest size the present data allow)" in html
    # no decisive measurement: the sentence names what mimics the effect
    doc["recommendations"][0].update(decisive=False, ranked_size="prior", absorbed_by=[
        {"parameter": "bearing.C_air", "delta_ln_p": 0.25}])
    html = diagnose_html(doc, [])
    assert "no offered measurement separates it" in html
    assert "at its prior's typical size, with <b>impedance:Shaft-Frame</b> at 300 rpm " \
           "measured, the network without it would still mimic it by moving bearing.C_air " \
           "(0.25 in ln p)" in html
    # ... or, when even the unrefitted separation is below the acceptance, says so
    doc["recommendations"][0].update(unrefitted_delta_chi2=0.44, acceptance_delta_chi2=19.2)
    html = diagnose_html(doc, [])
    assert "would change <b>impedance:Shaft-Frame</b> at 300 rpm by Δχ² 0.44, below the " \
           "19.2 the detective needs" in html


def test_refit_separation_is_what_the_refit_cannot_absorb(monkeypatch: pytest.MonkeyPatch
                                                          ) -> None:
    """Linear reference: the measurement's difference ``dm`` (Re part, sigma 0.01) against
    a network whose only free parameter moves it along ``g``. Along ``dm`` itself and
    without a prior the refit absorbs it all (0); orthogonal to it nothing (the fixed-value
    separation); with a prior of std s on the parameter, a difference c g costs
    ``c^2 |g|^2 / (1 + s^2 |g|^2)`` (ridge regression on one column, by hand)."""
    import vfmodel.detective.recommend as rc

    freq = np.geomspace(1e3, 1e6, 8)
    dm = 0.01 * np.linspace(1.0, 2.0, freq.size)               # ln(Z_a / Z_b), real
    ortho = np.where(np.arange(freq.size) % 2 == 0, 1.0, -1.0) * 1e-3
    ortho -= dm * (ortho @ dm) / (dm @ dm)
    monkeypatch.setattr(rc, "_shaft_frame", lambda fam, net, rpm, f: np.exp(
        dm if net == "a" else 0.0) * np.ones(f.size, complex))
    sig = 0.01

    def sep(direction: np.ndarray, prior_s: float | None) -> float:
        monkeypatch.setattr(rc, "_dlnz_dlnp",
                            lambda fam, net, names, rpm, f: direction[:, None] + 0j)
        row = np.zeros((1, 1)) if prior_s is None else np.full((1, 1), 1.0 / prior_s)
        present = rc._Refit(("p",), row, np.zeros(1), 0.0)
        return rc.refit_separation(None, "a", "b", 0.0, freq, sig, present)  # type: ignore[arg-type]

    full = rc.separation(cast(NDArray[np.complex128], dm + 0j), sig)
    assert sep(dm, None) == pytest.approx(0.0, abs=1e-9 * full)
    assert sep(ortho, None) == pytest.approx(full, rel=1e-9)
    s = 0.5
    g2 = float(dm @ dm) / sig**2
    assert sep(dm, s) == pytest.approx(g2 / (1 + s**2 * g2), rel=1e-9)
    # what absorbs it (direction dm, no prior): the one parameter, moved by exactly the
    # difference (ln p + 1)
    present = rc._Refit(("p",), np.zeros((1, 1)), np.zeros(1), 0.0)
    rows = rc.measurement_rows(None, "b", ("p",), 0.0, freq, sig)  # type: ignore[arg-type]
    _, fixed, moves = rc.refit_moves(None, "a", rows,  # type: ignore[arg-type]
                                     0.0, freq, sig, present)
    assert moves[0][0] == "p" and moves[0][1] == pytest.approx(1.0, rel=1e-9)
    assert fixed == pytest.approx(full, rel=1e-12)     # unrefitted: the whole difference


def test_size_bound_is_the_largest_size_the_present_data_absorb(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Linear reference: the present residual moves by ``x v`` with ``x = ln(p / p_fit)``
    and nothing refits it (no free parameter), so the refit misses ``t^2 X^2 |v|^2`` at the
    share ``t`` of the way to the prior (``X = ln(p_prior / p_fit)``). The bound at
    ``limit`` is ``t* = sqrt(limit) / (X |v|)``; the bisection finds it from below within
    ``2**-BOUND_STEPS``, and returns None when the prior size is absorbed or the fitted
    size is not."""
    import vfmodel.detective.recommend as rc

    v = np.array([3.0, -4.0, 12.0])                 # |v| = 13
    spec = ParamSpec("p", 1.0, 1e-6, 1e6, "lubricant", "", "")
    fit = Net((), ParamSet((spec,), (1.0,)))
    prior = Net((), ParamSet((spec,), (1e3,)))      # X = ln 1000
    monkeypatch.setattr(rc, "evaluate", lambda fam, applied, p: math.log(p["p"]) * v)
    present = rc._Present((), np.zeros((v.size, 0)), np.zeros(v.size))
    cmp = Comparison(("e",), fit, fit, 1, prior, ("p",))
    limit = 50.0
    found = rc.size_bound(None, cmp, present, limit)
    assert found is not None
    t, net, ref = found
    t_star = math.sqrt(limit) / (math.log(1e3) * 13.0)      # 0.0788
    assert t_star - 2.0**-rc.BOUND_STEPS <= t <= t_star
    assert ref.base <= limit
    assert net.params["p"] == pytest.approx(1e3**t, rel=1e-12)
    # the prior size absorbed (limit above the miss at t = 1): the bisection climbs to
    # 1 - 2**-BOUND_STEPS; the fitted size not absorbed: nothing
    assert rc.size_bound(None, cmp, present, 1e9)[0] == 1.0 - 2.0**-rc.BOUND_STEPS  # type: ignore[index]
    shifted = rc._Present((), np.zeros((v.size, 0)), -v)   # already missed at t = 0
    assert rc.size_bound(None, cmp, shifted, 100.0) is None


def test_ranked_size_is_the_largest_counted_separation() -> None:
    """The rank is the largest of the refit separations that count, and says which: the
    prior's size only when the present data leave it open, the bound when computed; a
    fixed-value separation (no refit) has no size."""
    import vfmodel.detective.recommend as rc

    assert rc._ranked(5.0, None, None, False) == (5.0, None)
    assert rc._ranked(5.0, 1.0, 9.0, False) == (1.0, "fitted")     # prior excluded
    assert rc._ranked(5.0, 1.0, 9.0, True) == (9.0, "prior")
    assert rc._ranked(5.0, 1.0, None, False, 30.0) == (30.0, "bound")
    assert rc._ranked(5.0, 40.0, None, False, 30.0) == (40.0, "fitted")


@dataclass
class _FreeStub(_Stub):
    """The stub without the edge capacitance, with the free values of the shaft-to-frame
    path (machine and bearing)."""

    def spec(self, applied: Sequence[Candidate]) -> NetSpec:
        base = PAPER_EFFECTS - {"metallic_contact", "hertzian_edge_capacitance"}
        return NetSpec(frozenset(base) | {c.effect for c in applied})

    def free_names(self, applied: Sequence[Candidate], params: ParamSet) -> tuple[str, ...]:
        groups = ("lubricant", "bearing", "ball", "shaft", "frame", "airgap")
        path = [n for n in params.names if n.split(".")[0] in groups and n != "bearing.C_edge"]
        return (*path, "insulation.C_wr")


def test_an_edge_capacitance_is_mimicked_below_the_contact_corner_only() -> None:
    """An edge capacitance of 1 nF (5 % of the 20 nF film) across the Hertzian contact
    resistance (0.5 ohm) and the film, the shaft-to-frame path held: the bearing's values
    of the network without it, refitted, reproduce it up to 1 MHz (far below the corner
    1 / (2 pi R_h C) = 16 MHz: an RC one-port either way, Foster form; omega R_h C = 0.06
    at 1 MHz) and miss it up to 100 MHz by many times the detective's acceptance
    (10 + k ln m, one parameter, 2 x 126 entries: 15.5)."""
    from vfmodel.detective.recommend import mimicked_on

    f = np.geomspace(1e3, 1e7, 101)
    fam = _FreeStub((Channel("impedance:U-Frame", f, np.ones(101, complex),
                             np.full(101, 0.005)),))
    p = default_params()
    edge = Candidate("hertzian_edge_capacitance", "bearing.contact")
    a, b = Net((edge,), p), Net((), p)
    w = wide_grid(f)
    assert w is not None
    assert mimicked_on(fam, a, b, 0.0, np.geomspace(1e3, 1e6, 61), 0.005) < 0.01
    assert mimicked_on(fam, a, b, 0.0, w, 0.005) > 5 * (10 + math.log(2 * w.size))
    # no edge: nothing to mimic (the start is the answer, 0 up to rounding)
    assert mimicked_on(fam, b, b, 0.0, w, 0.005) < 1e-12
