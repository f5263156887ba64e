"""Maximum a posteriori refits of the detective (issue 14, deliverable 1) and implausible
fitted values as evidence (deliverable 2).

Reference of the MAP test: a model linear in ``x = ln p`` with Gaussian noise and log-normal
priors has a Gaussian posterior; its mode and covariance solve the normal equations
``(A^T A + P) x = A^T y + P m`` (``P`` the prior precisions), computed here with
``numpy.linalg.solve``, independently of the least-squares solver the refit uses.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, cast

import numpy as np
import pytest

from vfmodel.detective.evidence import implausible_evidence
from vfmodel.detective.fit import refit
from vfmodel.detective.problem import Candidate, Family
from vfmodel.greybox.params import ParamSet, ParamSpec
from vfmodel.greybox.priors import Prior, parameter_priors

# data see only ln a + ln b (twice, sigma 0.1) and ln b - ln c (sigma 0.5)
A = np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, -1.0]])
SIG = np.array([0.1, 0.1, 0.5])
Y = np.array([math.log(6.0) + 0.03, math.log(6.0) - 0.01, math.log(0.5)])
NAMES = ("a", "b", "c")
P0 = ParamSet.from_specs(tuple(ParamSpec(n, 1.0, 1e-6, 1e6, "g") for n in NAMES))


def _prior(name: str, median: float, gsd: float) -> Prior:
    return Prior(name, "lognormal", median, gsd, median / gsd**3, median * gsd**3,
                 "physics", "test")


class _Linear:
    """Family of the module docstring's linear model."""

    channels = ()

    def __init__(self, priors: dict[str, Prior] | None) -> None:
        self.priors = priors

    def free_names(self, applied: Sequence[Candidate], params: ParamSet) -> tuple[str, ...]:
        return NAMES

    def residual(self, applied: Sequence[Candidate], params: ParamSet) -> np.ndarray:
        x = np.log([params[n] for n in NAMES])
        return np.asarray((A @ x - Y) / SIG)


def test_map_refit_is_the_gaussian_posterior() -> None:
    pri = {"a": _prior("a", 2.0, 1.5), "b": _prior("b", 2.5, 3.0), "c": _prior("c", 4.0, 2.0)}
    fit = refit(cast(Family, _Linear(pri)), (), P0)
    aw = A / SIG[:, None]
    prec = np.diag([1 / math.log(pri[n].gsd) ** 2 for n in NAMES])
    m = np.log([pri[n].median for n in NAMES])
    h = aw.T @ aw + prec
    x_ref = np.linalg.solve(h, aw.T @ (Y / SIG) + prec @ m)
    std_ref = np.sqrt(np.diag(np.linalg.inv(h)))
    x = np.log([fit.params[n] for n in NAMES])
    np.testing.assert_allclose(x, x_ref, atol=1e-6)
    np.testing.assert_allclose([fit.rel_std[n] for n in NAMES], std_ref, rtol=1e-6)
    r_data = (A @ x_ref - Y) / SIG
    r_prior = (x_ref - m) / np.sqrt(1 / np.diag(prec))
    assert fit.chi2 == pytest.approx(float(r_data @ r_data), rel=1e-6)
    assert fit.prior_chi2 == pytest.approx(float(r_prior @ r_prior), rel=1e-6)
    assert fit.bic == pytest.approx(fit.chi2 + fit.prior_chi2 + 3 * math.log(3), rel=1e-9)


def test_without_priors_the_unseen_direction_stays_unknown() -> None:
    fit = refit(cast(Family, _Linear(None)), (), P0)
    assert fit.prior_chi2 == 0.0
    # ln a - ln b is not seen by the data: both stds infinite (pseudo-inverse), c finite
    assert not math.isfinite(fit.rel_std["a"]) or fit.rel_std["a"] > 1e3
    x = np.log([fit.params[n] for n in NAMES])
    assert x[0] + x[1] == pytest.approx(math.log(6.0) + 0.01, abs=1e-6)


def test_a_range_prior_acts_only_outside_its_bounds() -> None:
    lo, hi = 0.5, 8.0
    rng = Prior("a", "range", math.sqrt(lo * hi), math.exp(math.log(hi / lo) / math.sqrt(12)),
                lo, hi, "physics", "test")
    pri = {"a": rng, "b": _prior("b", 1.0, 1.2), "c": _prior("c", 4.0, 2.0)}
    fit = refit(cast(Family, _Linear(pri)), (), P0)
    # b pinned near 1 by its prior, so a ~ 6 (inside the range): the range costs nothing
    assert lo < fit.params["a"] < hi
    assert fit.params["a"] * fit.params["b"] == pytest.approx(6.0 * math.exp(0.01), rel=2e-3)


# ------------------------------------------------------------------ evidence
PRI = parameter_priors(None, 0.0)
PRI_100 = parameter_priors(None, 100.0)


def _ev(values: dict[str, float], found: dict[str, str] | None = None,
        rejected: dict[str, str] | None = None) -> list[dict[str, Any]]:
    pri = {n: (PRI_100[n.split("@")[0]] if "@" in n else PRI[n]) for n in values}
    return implausible_evidence(values, pri, frozenset({"lubricant_two_layer"}),
                                found or {}, rejected or {})


def test_a_shorted_standstill_film_points_at_the_metallic_contact() -> None:
    c1 = PRI["lubricant.C_1"]
    ev = _ev({"lubricant.C_1": c1.median * c1.gsd**5, "insulation.C_wr":
              PRI["insulation.C_wr"].median},
             rejected={"metallic_contact": "not supported by the data"})
    assert [e["parameter"] for e in ev] == ["lubricant.C_1"]
    assert ev[0]["z_sigma"] == pytest.approx(5.0, rel=1e-9)
    (ex,) = ev[0]["explained_by"]
    assert ex["effect"] == "metallic_contact"
    assert ex["outcome"] == "rejected: not supported by the data"


def test_a_large_film_at_speed_points_at_the_bearing_capacitances_not_the_contact() -> None:
    c1 = PRI_100["lubricant.C_1"]
    ev = _ev({"lubricant.C_1@100rpm": c1.median * c1.gsd**4},
             found={"hertzian_edge_capacitance": "bearing.contact"})
    effects = {e["effect"]: e["outcome"] for e in ev[0]["explained_by"]}
    assert effects == {"hertzian_edge_capacitance": "found at bearing.contact",
                       "lubricant_two_layer": "already in the network"}


def test_values_within_three_sigma_are_not_evidence() -> None:
    c1 = PRI["lubricant.C_1"]
    assert _ev({"lubricant.C_1": c1.median * c1.gsd**2.9}) == []


def test_priors_with_a_user_model_are_refused() -> None:
    """A ``--model`` network has no physical priors: one message naming the option."""
    from pathlib import Path

    from vfmodel.errors import InputError
    from vfmodel.pipeline.diagnose import run_diagnose

    repo = Path(__file__).resolve().parents[1]
    with pytest.raises(InputError, match="--priors: applies to the PMSM model only"):
        run_diagnose(repo / "data" / "concealed" / "rc_null", priors=True,
                     model=repo / "data" / "user-models" / "rc_ladder.net")
