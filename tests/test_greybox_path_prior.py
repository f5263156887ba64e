"""Machine covariance with the path known only through its prior (greybox.path_prior):
against the exact covariance of a linear least-squares estimator whose path parameters
are drawn from their prior."""

from __future__ import annotations

import math

import numpy as np

from vfmodel.greybox.identify import StageReport
from vfmodel.greybox.params import ParamSet, ParamSpec
from vfmodel.greybox.path_prior import prior_second_moment, with_path_prior
from vfmodel.greybox.priors import Prior

OTHER = ("insulation.C_wr", "winding.U.L_w")
PATH = ("shaft.L_1", "shaft.L_2")
HELD = ("airgap.C_rf",)


def _prior(name: str, median: float, gsd: float) -> Prior:
    return Prior(name, "lognormal", median, gsd, median / gsd**3, median * gsd**3,
                 "physics", "test")


def _setup() -> tuple[np.ndarray, np.ndarray, float, ParamSet, dict[str, Prior]]:
    rng = np.random.default_rng(3)
    m = 300
    a = rng.standard_normal((m, 2))                  # columns of OTHER (log parameters)
    b = 0.8 * a @ rng.standard_normal((2, 2)) + 0.2 * rng.standard_normal((m, 2))
    sig2 = 0.01
    names = OTHER + PATH + HELD
    vals = (2e-10, 1e-4, 1e-6, 3e-8, 1e-9)           # the fit (shaft.L_1 far from physics)
    params = ParamSet(tuple(ParamSpec(n, v, v * 1e-6, v * 1e6, n.split(".")[0], "", "")
                            for n, v in zip(names, vals, strict=True)), vals)
    priors = {"shaft.L_1": _prior("shaft.L_1", 7e-8, 2.7),
              "shaft.L_2": _prior("shaft.L_2", 7e-8, 2.7),
              "airgap.C_rf": _prior("airgap.C_rf", 1.3e-9, 1.9)}
    return a, b, sig2, params, priors


def test_prior_second_moment_is_variance_plus_offset() -> None:
    _, _, _, params, priors = _setup()
    m = prior_second_moment(priors, params, PATH)
    d = np.array([math.log(7e-8 / 1e-6), math.log(7e-8 / 3e-8)])
    assert np.allclose(m, np.diag([math.log(2.7) ** 2] * 2) + np.outer(d, d), rtol=1e-12)


def test_path_prior_matches_the_linear_estimator_with_drawn_path() -> None:
    a, b, sig2, params, priors = _setup()
    j = np.hstack([a, b])
    cov = sig2 * np.linalg.inv(j.T @ j)              # as fit_stage reports a stage
    rep = StageReport("standstill 0 rpm", OTHER + PATH, 300, sig2, 5, 1, {}, cov)
    out = with_path_prior(rep, params, priors, path=PATH, held=HELD)
    assert out.names == OTHER + PATH + HELD
    assert out.cov_log is not None
    # reference: theta_o re-estimated with theta_P given, theta_o = (A^T A)^-1 A^T (y -
    # B theta_P): it moves by K (theta_P - theta_P_fit), K = -(A^T A)^-1 A^T B, and its
    # noise covariance is sig2 (A^T A)^-1; theta_P about the fit has second moment M
    ata_inv = np.linalg.inv(a.T @ a)
    k = -ata_inv @ a.T @ b
    m = prior_second_moment(priors, params, PATH + HELD)
    kk = np.hstack([k, np.zeros((2, 1))])
    ref = np.block([[sig2 * ata_inv + kk @ m @ kk.T, kk @ m], [(kk @ m).T, m]])
    assert np.allclose(out.cov_log, ref, rtol=1e-8, atol=1e-14)
    # the same by drawing: theta_P from its prior, the record's noise, re-estimation
    rng = np.random.default_rng(5)
    n = 20000
    mu = np.log([7e-8, 7e-8])
    xp = mu + np.log(2.7) * rng.standard_normal((n, 2)) - np.log([1e-6, 3e-8])
    noise = np.sqrt(sig2) * rng.standard_normal((n, 300))
    dev = xp @ k.T + noise @ (a @ ata_inv)          # theta_o minus its fit, per draw
    mc = dev.T @ dev / n
    assert np.allclose(mc, ref[:2, :2], rtol=0.05)


def test_report_without_path_or_covariance_is_unchanged() -> None:
    _, _, _, params, priors = _setup()
    rep = StageReport("impedance", OTHER, 10, 1.0, 3, 1, {}, None)
    assert with_path_prior(rep, params, priors, path=PATH) is rep
    rep2 = StageReport("impedance", OTHER, 10, 1.0, 3, 1, {}, np.eye(2))
    assert with_path_prior(rep2, params, priors, path=PATH) is rep2


def test_unseen_parameters_stay_unbounded() -> None:
    _, _, _, params, priors = _setup()
    cov = np.diag([0.01, np.inf, 0.02, 0.03])
    cov[0, 2] = cov[2, 0] = 0.01
    rep = StageReport("standstill 0 rpm", OTHER + PATH, 10, 1.0, 3, 1, {}, cov)
    out = with_path_prior(rep, params, priors, path=PATH)
    assert out.cov_log is not None
    assert np.isinf(out.cov_log[1, 1])
    assert np.all(np.isfinite(out.cov_log[np.ix_([0, 2, 3], [0, 2, 3])]))
    assert out.cov_log[0, 0] > 0.01
