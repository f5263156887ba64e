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
theorem at the optimum; ``sigma``: the fit's weak prior). The inverse is the stage's own
covariance divided by its scale: :func:`.identify.fit_stage` reports
``C_l = chi2_red * corr_factor * (J_l^T J_l + I / sigma^2)^+``. With the machine
covariance ``Sigma_m`` of the last machine stage,

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
                             machine: StageReport, *,
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
    scale = max(report.chi2_red * report.corr_factor, 1e-300)
    # unseen directions carry infinite variances (log_covariance): they stay infinite,
    # and so does every lubricant parameter that moves with an unseen machine parameter
    c_l = np.where(np.isfinite(report.cov_log), report.cov_log, 0.0)
    s = -(c_l / scale) @ (jl.T @ jm)
    s[~np.isfinite(np.diag(report.cov_log))] = 0.0
    unseen = ~np.isfinite(np.diag(sig_m))
    sig_f = np.where(np.isfinite(sig_m), sig_m, 0.0)
    c_ll = report.cov_log + s @ sig_f @ s.T
    c_lm = s @ sig_f
    moved = np.any(s[:, unseen] != 0.0, axis=1)
    c_ll[np.ix_(moved, moved)] = np.inf
    c_lm[np.ix_(moved, unseen)] = np.inf
    cov = np.block([[c_ll, c_lm], [c_lm.T, sig_m]])
    names = lub + mach
    rel = np.sqrt(np.maximum(np.diag(cov), 0.0))
    return StageReport(report.name, names, report.n_residuals, report.chi2_red, report.nfev,
                       report.status, {n: float(v) for n, v in zip(names, rel, strict=True)},
                       cov, report.corr_factor)
