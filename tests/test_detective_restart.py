"""The detective re-identifies an accepted network (``family.restart``) and keeps the
better of that refit and the warm-started one (vfmodel.detective.diagnose._restarted)."""

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
    def fake_refit(family: Any, applied: Any, params: ParamSet, **kw: Any) -> FitResult:
        return _fit(refit_chi2, params["a"])

    monkeypatch.setattr(dg, "refit", fake_refit)
    fam = _Family(start)
    got = dg._restarted(fam, _fit(20.0, 1.0), 30, lambda *a: None)  # type: ignore[arg-type]
    assert got.params["a"] == expect_a
    assert fam.asked == [((CAND,), 1.0)]


def test_family_without_restart_is_left_alone() -> None:
    f = _fit(20.0, 1.0)
    assert dg._restarted(object(), f, 30, lambda *a: None) is f  # type: ignore[arg-type]
