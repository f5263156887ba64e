"""Lubricant intervals that carry the uncertainty of the machine they were fitted on.

Each speed's lubricant is fitted with the machine fixed at the values of the machine stages
(spectra, standstill record). Its stage covariance is therefore conditional on those
values: at standstill the closed contact lets the data fix only the product of the
winding-rotor capacitance and the impedance of the rotor current's path, so ``C_wr`` and
``C_rf`` may be uncertain by a factor of 2-3 while the lubricant's covariance says
0.1 %. A bearing capacitance read from the lubricant then inherits that factor (the
record fixes the divider ratio ``C_wr / (C_wr + C_rf + 2 C_b)``, not the scale).

The two-step estimator's covariance (Murphy & Topel 1985): with ``J_l``, ``J_m`` the
record residual's derivatives by the log lubricant and log machine parameters,
``S = d theta_l / d theta_m = -(J_l^T J_l + I / sigma^2)^+ J_l^T J_m`` (implicit function
theorem at the optimum; ``sigma``: the fit's weak prior), and the machine covariance
``Sigma_m`` of the last machine stage,

    Cov(theta_l, theta_m) = [[C_l + S Sigma_m S^T, S Sigma_m], [Sigma_m S^T, Sigma_m]].

K. M. Murphy, R. H. Topel, "Estimation and inference in two-step econometric models",
J. Business & Economic Statistics 3(4), 370-379, 1985.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vfmodel.greybox.identify import StageReport
from vfmodel.greybox.joint import SHARED
from vfmodel.greybox.params import ParamSet

__all__ = ["with_machine_uncertainty"]


def with_machine_uncertainty(term: object, params: ParamSet, report: StageReport,
                             machine: StageReport, *, prior_sigma: float = 1.0,
                             machine_names: Sequence[str] = SHARED) -> StageReport:
    """``report`` (a lubricant stage) extended by the ``machine_names`` of ``machine``
    (the last machine stage) with the covariance above. Returned unchanged when it
    already holds them (a joint stage) or when either covariance is missing."""
    if report.cov_log is None or machine.cov_log is None:
        return report
    lub = tuple(report.names)
    if any(n in lub for n in machine_names):
        return report
    idx = {n: k for k, n in enumerate(machine.names)}
    mach = tuple(n for n in machine_names if n in idx and n in params)
    if not mach:
        return report
    sel = [idx[n] for n in mach]
    sig_m = machine.cov_log[np.ix_(sel, sel)]
    _, jac = term.residual(params, lub + mach, jac=True)  # type: ignore[attr-defined]
    jl, jm = jac[:, :len(lub)], jac[:, len(lub):]
    a = jl.T @ jl + (np.eye(len(lub)) / prior_sigma**2 if prior_sigma > 0 else 0.0)
    s = -np.linalg.pinv(a) @ (jl.T @ jm)
    finite = np.all(np.isfinite(sig_m))
    if finite:
        c_ll = report.cov_log + s @ sig_m @ s.T
        c_lm = s @ sig_m
    else:  # an unseen machine direction leaves the lubricant unbounded along it
        c_ll = np.full_like(report.cov_log, np.inf)
        c_lm = np.full((len(lub), len(mach)), np.inf)
    cov = np.block([[c_ll, c_lm], [c_lm.T, sig_m]])
    names = lub + mach
    rel = np.sqrt(np.maximum(np.diag(cov), 0.0))
    return StageReport(report.name, names, report.n_residuals, report.chi2_red, report.nfev,
                       report.status, {n: float(v) for n, v in zip(names, rel, strict=True)},
                       cov, report.corr_factor)
