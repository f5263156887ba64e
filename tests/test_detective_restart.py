"""The detective re-identifies an accepted network (``family.restart``) when the effect
explained at least half of the misfit, and keeps the better of the refit from there and
the warm-started fit (vfmodel.detective.diagnose._restarted)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import vfmodel.detective.diagnose as dg
from vfmodel.detective.fit import FitResult
from vfmodel.detective.problem import Candidate
from vfmodel.greybox.params import ParamSet, ParamSpec

P = ParamSet.from_specs((ParamSpec("a", 1.0, 0.1, 10.0, "g", "", "a"),))
CAND = Candidate("metallic_contact", "bearing.contact")


def _fit(chi2: float, a: float) -> FitResult:
    return FitResult((CAND,), P.with_values({"a": a}), ("a",), np.zeros(4), chi2, 4,
                     {"a": 0.1}, np.eye(1))


class _Family:
    def __init__(self, start: float | None) -> None:
        self.start = start
        self.asked: list[Any] = []

    def restart(self, applied: Any, params: ParamSet) -> ParamSet | None:
        self.asked.append((applied, params["a"]))
        return None if self.start is None else params.with_values({"a": self.start})


@pytest.mark.parametrize(("start", "refit_chi2", "expect_a"),
                         [(3.0, 5.0, 3.0),       # the re-identified start fits better
                          (3.0, 50.0, 1.0),      # worse: the warm-started fit stays
                          (None, 0.0, 1.0)])     # the family has no identification
def test_restart_keeps_the_better(monkeypatch: pytest.MonkeyPatch, start: float | None,
                                  refit_chi2: float, expect_a: float) -> None:
    budgets: list[int] = []

    def fake_refit(family: Any, applied: Any, params: ParamSet, **kw: Any) -> FitResult:
        budgets.append(kw["max_nfev"])
        return _fit(refit_chi2, params["a"])

    monkeypatch.setattr(dg, "refit", fake_refit)
    fam = _Family(start)
    # base chi2 100 -> warm-started 20: the effect explained 80 % of the misfit
    got = dg._restarted(fam, _fit(100.0, 0.5), _fit(20.0, 1.0), 30,  # type: ignore[arg-type]
                        lambda *a: None)
    assert got.params["a"] == expect_a
    assert fam.asked == [((CAND,), 1.0)]
    assert budgets == ([] if start is None else [30])


@pytest.mark.parametrize("base_chi2", [40.0, 39.0, 21.0])
def test_no_restart_when_the_effect_explains_less_than_half(base_chi2: float) -> None:
    # 20 of 40 is not below half: the warm-started fit is kept, nothing re-identified
    fam = _Family(3.0)
    f = _fit(20.0, 1.0)
    assert dg._restarted(fam, _fit(base_chi2, 0.5), f, 30,  # type: ignore[arg-type]
                         lambda *a: None) is f
    assert fam.asked == []


def test_family_without_restart_is_left_alone() -> None:
    f = _fit(20.0, 1.0)
    assert dg._restarted(object(), _fit(100.0, 0.5), f, 30,  # type: ignore[arg-type]
                         lambda *a: None) is f
