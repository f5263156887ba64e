"""Passivity enforcement ends at the smallest certified fraction of the programs' change
(vfmodel.fitting._enforce._shrink): the programs resolve changes only to about 1e-10 of
the response, however small the violation. Reference: a one-pole S model scaled by 1 + v
(v = 1e-12) violates by v at 0 Hz; dividing it by 1 + v is passive and changes it by
v / (1 + v), so the least change is at most that."""

from __future__ import annotations

import numpy as np
import pytest

from vfmodel import FrequencyData, RationalModel
from vfmodel.fitting import _enforce, check_passivity, enforce_passivity


def _case() -> tuple[RationalModel, FrequencyData, np.ndarray, float]:
    b, v = 2 * np.pi * 1e9, 1e-12
    model = RationalModel(np.array([-b + 0j]), np.array([[[(1 + v) * b + 0j]]]), kind="S")
    f = np.geomspace(1e5, 1e10, 301)
    return model, FrequencyData(f, model(f), kind="S"), f, v


def _change(a: RationalModel, b: RationalModel, f: np.ndarray) -> float:
    return float(np.linalg.norm(a(f) - b(f)) / np.linalg.norm(b(f)))


def test_enforced_change_is_near_the_violation() -> None:
    model, data, f, v = _case()
    assert not check_passivity(model).passive
    enforced, rep = enforce_passivity(model, data=data, margin=1e-10, keep_margin=False)
    assert rep.passive and check_passivity(enforced).passive
    # measured: 4.3e-13 (the violation is at the lowest frequencies only)
    assert _change(enforced, model, f) <= v / (1 + v)


def test_without_the_fraction_the_change_is_the_margins(monkeypatch: pytest.MonkeyPatch) -> None:
    model, data, f, v = _case()
    monkeypatch.setattr(_enforce, "_shrink", lambda m, p, r, *a: (p, r))
    enforced, rep = enforce_passivity(model, data=data, margin=1e-10, keep_margin=False)
    assert rep.passive
    # the programs alone: a change of the order of the margin (measured 4.4e-10)
    assert _change(enforced, model, f) > 10 * v


def test_a_margin_kept_is_not_given_back() -> None:
    # keep_margin=True (the default, and run_fit's with --enforce-margin): the fraction
    # must keep the required margin at the cut frequencies; the violation is at 0 Hz
    model, data, f, _ = _case()
    margin = 1e-6
    enforced, rep = enforce_passivity(model, data=data, margin=margin)
    assert rep.passive
    sigma_dc = float(np.abs(enforced(np.array([0.0]))[0, 0, 0]))
    assert sigma_dc <= 1.0 - 0.9 * margin
    relaxed, _ = enforce_passivity(model, data=data, margin=margin, keep_margin=False)
    # the margin given back: 10 bisection steps resolve 1/1024 of the change (measured
    # 9.8e-10 against the kept model's change of the order of the margin)
    assert _change(relaxed, model, f) < 2e-3 * _change(enforced, model, f)
