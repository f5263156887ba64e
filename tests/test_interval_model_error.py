"""The structural model-error term of the 95 % intervals (vfmodel.greybox.model_error, issue 19)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vfmodel.greybox.lsq import log_interval
from vfmodel.greybox.model_error import plateau_discrepancy
from vfmodel.greybox.params import ParamSet, ParamSpec
from vfmodel.signals.h1 import h1_analysis


@dataclass(frozen=True)
class _Report:
    names: tuple[str, ...]
    cov_log: NDArray[np.float64] | None


def _params() -> ParamSet:
    return ParamSet.from_specs([ParamSpec("a", 2.0, 1e-3, 1e3, "x"),
                                 ParamSpec("b", 5.0, 1e-3, 1e3, "x")])


def test_regression_on_the_anchor_matches_the_analytic_value() -> None:
    # log q = log a, anchor log h = log a + log b, C = diag(s1^2, s2^2): the posterior
    # regression of log q on log h is beta = s1^2 / (s1^2 + s2^2)
    s1, s2, tau = 0.02, 0.04, 0.05
    rep = _Report(("a", "b"), np.diag([s1**2, s2**2]))
    p = _params()

    def anchor(q: ParamSet) -> float:
        return q["a"] * q["b"]

    iv = log_interval(p, rep, lambda q: q["a"], anchor=anchor, anchor_tau=tau)
    beta = s1**2 / (s1**2 + s2**2)
    assert iv["std_log_noise"] is not None and abs(iv["std_log_noise"] - s1) < 1e-6
    assert iv["model_error_log"] is not None and abs(iv["model_error_log"] - beta * tau) < 1e-6
    assert iv["std_log"] is not None
    assert abs(iv["std_log"] - np.hypot(s1, beta * tau)) < 1e-6
    # the anchor itself gets tau whole: sqrt(s1^2 + s2^2 + tau^2)
    ia = log_interval(p, rep, anchor, anchor=anchor, anchor_tau=tau)
    assert ia["std_log"] is not None
    assert abs(ia["std_log"] - np.sqrt(s1**2 + s2**2 + tau**2)) < 1e-6
    # the regression taken in a stage that moves only ``a`` (b held): beta = 1
    held = log_interval(p, rep, lambda q: q["a"], anchor=anchor, anchor_tau=tau,
                        anchor_report=_Report(("a",), np.array([[s1**2]])))
    assert held["std_log"] is not None and abs(held["std_log"] - np.hypot(s1, tau)) < 1e-6
    # without the term the interval is the noise interval (unchanged API)
    plain = log_interval(p, rep, lambda q: q["a"])
    assert plain["std_log"] is not None and abs(plain["std_log"] - s1) < 1e-6
    assert "model_error_log" not in plain


def _record(seed: int, gain: float, n: int = 2**17) -> tuple[NDArray[np.float64], ...]:
    """Three correlated inputs (a common mode plus differential parts) and an output
    ``gain * sum(x) + noise`` (a frequency-flat common-mode transfer ``3 gain``)."""
    rng = np.random.default_rng(seed)
    cm = rng.standard_normal(n)
    x = cm + 0.5 * rng.standard_normal((3, n))
    y_clean = gain * x.sum(axis=0)
    return x, y_clean, y_clean + 0.01 * rng.standard_normal(n)


def test_discrepancy_recovers_a_known_structural_error_and_the_noise() -> None:
    x, y_clean, y = _record(7, 0.01)
    fs = 1e6
    meas = h1_analysis(x, y, fs, nperseg=512)
    mask = meas.valid & (meas.freq_hz > 0)
    hm = meas.h[mask, 0, :]
    # a model 3 % low (structural error log(1 / 0.97)) seen through the same estimator
    low = h1_analysis(x, 0.97 * y_clean, fs, nperseg=512).h[mask, 0, :]
    d = plateau_discrepancy(meas, mask, hm, low, f0_hz=100e3, octaves=1.0)
    assert d.freq_hz.size == 77  # bins of 1.95 kHz from 50 to 200 kHz
    assert abs(d.tau - np.log(1 / 0.97)) < 0.1 * np.log(1 / 0.97)
    # an exact model: the log ratios are noise only, and their mean square equals the
    # predicted noise variance (within 30 % for 77 bins; a factor 2 would fail)
    exact = h1_analysis(x, y_clean, fs, nperseg=512).h[mask, 0, :]
    e = plateau_discrepancy(meas, mask, hm, exact, f0_hz=100e3, octaves=1.0)
    ratio = float(np.mean(e.log_ratio**2) / np.mean(e.noise_var))
    assert 0.7 < ratio < 1.3, ratio
    assert e.tau < 0.5 * d.tau
