"""Lubricant intervals with the machine's uncertainty (greybox.propagate): the two-step
covariance against the exact covariance of a linear two-step estimator."""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np
from numpy.typing import NDArray

from vfmodel.greybox.identify import StageReport
from vfmodel.greybox.params import ParamSet, ParamSpec
from vfmodel.greybox.propagate import with_machine_uncertainty

LUB = ("lubricant.R_1", "lubricant.C_1")
MACH = ("insulation.C_wr", "airgap.C_rf", "ball.R_dc")


class _Linear:
    """Residual ``y - A theta_l - B theta_m`` (log parameters), Jacobian by name."""

    def __init__(self, a: np.ndarray, b: np.ndarray) -> None:
        self.cols = dict(zip(LUB + MACH, np.hstack([a, b]).T, strict=True))

    def residual(self, params: ParamSet, names: Sequence[str] = (),
                 jac: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
        j = np.stack([-self.cols[n] for n in names], axis=1)
        return np.zeros(j.shape[0]), j


def test_two_step_covariance_matches_the_linear_estimator() -> None:
    rng = np.random.default_rng(8)
    m = 200
    a = rng.standard_normal((m, 2))
    b = 0.5 * a @ rng.standard_normal((2, 3)) + 0.3 * rng.standard_normal((m, 3))
    sig2 = 0.04                                        # noise variance of the record
    q = rng.standard_normal((3, 3))
    sig_m = q @ q.T * 0.01                             # covariance of the machine stage
    ata_inv = np.linalg.inv(a.T @ a)
    cond = cast(NDArray[np.float64], sig2 * ata_inv)
    params = ParamSet(tuple(ParamSpec(n, 1.0, 1e-3, 1e3, n.split(".")[0], "", "")
                            for n in LUB + MACH), (1.0,) * 5)
    # as fit_stage reports it: chi2_red times (J^T J)^-1 (here chi2_red = the noise
    # variance, the residual not whitened)
    lub_rep = StageReport("lubricant 100 rpm", LUB, m, sig2, 5, 1,
                          {n: 0.0 for n in LUB}, cond)
    mach_rep = StageReport("standstill 0 rpm", (*MACH, "winding.U.R_w"), m, 1.0, 5, 1,
                           {}, np.pad(sig_m, ((0, 1), (0, 1))) + np.diag([0, 0, 0, 1.0]))
    out = with_machine_uncertainty(_Linear(a, b), params, lub_rep, mach_rep,
                                   machine_names=MACH)
    # reference: theta_l = (A^T A)^-1 A^T (y - B theta_m) with theta_m ~ (., Sigma_m)
    # independent of the record noise: Cov = sig2 (A^T A)^-1 + K Sigma_m K^T,
    # K = (A^T A)^-1 A^T B; Cov(theta_l, theta_m) = -K Sigma_m
    k = ata_inv @ a.T @ b
    ref = np.block([[cond + k @ sig_m @ k.T, -k @ sig_m], [-(k @ sig_m).T, sig_m]])
    assert out.names == LUB + MACH
    assert out.cov_log is not None
    assert np.allclose(out.cov_log, ref, rtol=1e-10, atol=1e-14)


def test_joint_report_is_left_as_it_is() -> None:
    params = ParamSet(tuple(ParamSpec(n, 1.0, 1e-3, 1e3, "x", "", "") for n in LUB + MACH),
                      (1.0,) * 5)
    joint = StageReport("joint 100 rpm", MACH + LUB, 10, 1.0, 5, 1, {}, np.eye(5))
    mach = StageReport("standstill 0 rpm", MACH, 10, 1.0, 5, 1, {}, np.eye(3))
    assert with_machine_uncertainty(None, params, joint, mach, machine_names=MACH) is joint


def test_unseen_machine_direction_leaves_what_moves_with_it_unbounded() -> None:
    rng = np.random.default_rng(9)
    a = rng.standard_normal((50, 2))
    b = np.zeros((50, 3))
    b[:, 0] = a[:, 0] + 0.1 * rng.standard_normal(50)  # lubricant 0 moves with C_wr
    params = ParamSet(tuple(ParamSpec(n, 1.0, 1e-3, 1e3, "x", "", "") for n in LUB + MACH),
                      (1.0,) * 5)
    lub_rep = StageReport("lubricant 100 rpm", LUB, 50, 1.0, 5, 1, {},
                          cast(NDArray[np.float64], np.linalg.inv(a.T @ a)))
    sig_m = np.diag([np.inf, 0.01, 0.01])               # C_wr not seen by the machine stage
    out = with_machine_uncertainty(_Linear(a, b), params, lub_rep,
                                   StageReport("standstill 0 rpm", MACH, 50, 1.0, 5, 1, {},
                                               sig_m), machine_names=MACH)
    assert out.cov_log is not None
    d = np.diag(out.cov_log)
    # reference: lubricant 0 moves with the unseen C_wr (infinite); lubricant 1 only
    # through its correlation with lubricant 0 in (A^T A)^-1, so it is unbounded too unless
    # that correlation is zero; the seen machine parameters keep their variances
    k = np.linalg.inv(a.T @ a) @ a.T @ b
    assert np.isinf(d[0]) and np.isinf(d[1]) == (abs(k[1, 0]) > 0)
    assert np.allclose(d[3:], [0.01, 0.01])
