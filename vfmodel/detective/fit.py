"""Refit of a candidate network: bounded least squares of the noise-normalised residual.

Parameters are varied as ``x = log(value)`` inside their bounds (trust-region reflective
least squares). The Jacobian is the family's own (``residual_jacobian(applied, params,
names)``, e.g. adjoint sensitivities) when it has one, else forward differences of its
prediction (one network solve per parameter). The fit statistics follow from the
noise-normalised residual ``r``: ``chi2 = r.r``,
``chi2_red = chi2 / (m - k)``, the Bayesian information criterion ``BIC = chi2 + k ln m``
(Gaussian noise of known variance, so ``-2 ln L = chi2`` up to a constant), and the
Gauss-Newton covariance ``(J^T J)^-1`` of ``log p`` (standard deviations and correlations;
a correlation near 1 means two parameters trade off against each other within the noise).

A family with physical priors (attribute ``priors``: name -> :class:`vfmodel.greybox.
priors.Prior`, e.g. :func:`vfmodel.detective.pmsm.pmsm_family` with ``priors=True``) is
fitted maximum a posteriori: the whitened prior residuals of ``ln p`` are stacked below
the data residuals, so the fit minimises ``chi2 + chi2_prior`` (``-2 ln`` posterior up to a
constant), the covariance is the posterior one (data and prior information), and
``BIC = chi2 + chi2_prior + k ln m``.

References
----------
G. Schwarz, "Estimating the dimension of a model", Ann. Statist. 6(2), 461-464, 1978.
doi:10.1214/aos/1176344136
M. A. Branch, T. F. Coleman, Y. Li, SIAM J. Sci. Comput. 21(1), 1-23, 1999.
doi:10.1137/S1064827595289108
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from contextlib import nullcontext
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vfmodel.detective.problem import Candidate, Family, log_residual
from vfmodel.greybox.lsq import fit_log, log_covariance, log_start
from vfmodel.greybox.params import ParamSet
from vfmodel.greybox.priors import prior_rows

__all__ = ["FitResult", "evaluate", "refit"]

ArrF = NDArray[np.float64]
_FD_STEP = 1e-6


@dataclass(frozen=True)
class FitResult:
    """A fitted network.

    Attributes
    ----------
    applied : tuple of Candidate
    params : ParamSet
    names : tuple of str
        Fitted parameters.
    residual : (m,) float
        Noise-normalised residual on every point (module layout of
        :mod:`vfmodel.detective.problem`), also where the fit used only a subset.
    chi2 : float
        ``r.r`` over the fitted points.
    n_points : int
        Residual entries fitted (``m``).
    rel_std : dict
        Standard deviation of ``log p`` of each fitted parameter (relative uncertainty).
    corr : (k, k) float
        Correlation matrix of ``log p`` (order of ``names``).
    prior_chi2 : float
        ``r_p.r_p`` of the whitened prior residuals of the fitted parameters (0 for a fit
        without priors, see :func:`refit`); ``rel_std`` and ``corr`` are then posterior.
    """

    applied: tuple[Candidate, ...]
    params: ParamSet
    names: tuple[str, ...]
    residual: ArrF
    chi2: float
    n_points: int
    rel_std: dict[str, float]
    corr: ArrF
    prior_chi2: float = 0.0

    @property
    def k(self) -> int:
        return len(self.names)

    @property
    def chi2_red(self) -> float:
        return self.chi2 / max(self.n_points - self.k, 1)

    @property
    def objective(self) -> float:
        """What the fit minimised: ``chi2 + prior_chi2`` (``-2 ln`` posterior up to a
        constant; ``chi2`` without priors)."""
        return self.chi2 + self.prior_chi2

    @property
    def bic(self) -> float:
        """``objective + k ln m``: with priors the data's chi-square plus the prior's
        (a candidate whose values physics makes implausible pays for them)."""
        return self.objective + self.k * float(np.log(max(self.n_points, 2)))


def evaluate(family: Family, applied: Sequence[Candidate], params: ParamSet) -> ArrF:
    """Noise-normalised residual of the network ``applied`` at ``params`` (the family's
    own ``residual(applied, params)`` when it has one, e.g. whitened transfer estimates)."""
    own = getattr(family, "residual", None)
    if own is not None:
        return np.asarray(own(applied, params), dtype=float)
    return log_residual(family.channels, family.predict(applied, params))


def _covariance(jac: ArrF) -> tuple[ArrF, ArrF]:
    """Standard deviations and correlation of the parameters from ``(J^T J)^+``
    (:func:`vfmodel.greybox.lsq.log_covariance`; an unseen direction: infinite std)."""
    k = jac.shape[1]
    if k == 0:
        return np.zeros(0), np.zeros((0, 0))
    cov = log_covariance(jac, rcond=1e-12)
    std = np.sqrt(np.maximum(np.diag(cov), 0.0))
    finite = np.where(np.isfinite(cov), cov, 0.0)     # correlations of the seen directions
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = finite / np.outer(np.where(std > 0, std, 1.0), np.where(std > 0, std, 1.0))
    corr = np.nan_to_num(np.clip(corr, -1.0, 1.0))
    return std, corr


def refit(family: Family, applied: Sequence[Candidate], params: ParamSet,
          names: Sequence[str] | None = None, *, rows: NDArray[np.bool_] | None = None,
          max_nfev: int = 60) -> FitResult:
    """Fit ``names`` (default: the family's free parameters) of the network ``applied``.

    ``rows`` selects the residual entries the fit uses (held-out validation fits on a
    subset of the points); the returned ``residual`` covers every point.
    """
    applied = tuple(applied)
    names = tuple(family.free_names(applied, params) if names is None else names)
    x0, lo, hi = log_start(params, names)
    sel = slice(None) if rows is None else rows

    def fun(x: ArrF) -> ArrF:
        return evaluate(family, applied, params.from_log(x, names))[sel]

    analytic = getattr(family, "residual_jacobian", None)
    last: dict[bytes, ArrF] = {}

    def jac(x: ArrF) -> ArrF:
        # the last Jacobian is kept: the solver's final point is usually a point where it
        # already asked for it, and the covariance below needs it again
        key = x.tobytes()
        if key not in last:
            last.clear()
            last[key] = _jac(x)
        return last[key]

    def _jac(x: ArrF) -> ArrF:
        if analytic is not None:
            return np.asarray(analytic(applied, params.from_log(x, names), names)[1])[sel]
        r0 = fun(x)
        cols = []
        for j in range(x.size):
            h = _FD_STEP if x[j] + _FD_STEP <= hi[j] else -_FD_STEP
            x1 = x.copy()
            x1[j] += h
            cols.append((fun(x1) - r0) / h)
        return np.stack(cols, axis=1) if cols else np.zeros((r0.size, 0))

    prior = _prior_rows(family, names)

    def fun_map(x: ArrF) -> ArrF:
        return np.concatenate([fun(x), prior(x)[0]])

    def jac_map(x: ArrF) -> ArrF:
        return np.vstack([jac(x), prior(x)[1]])

    # a family that can run its terms side by side keeps worker processes for the fit
    opener = getattr(family, "evaluation_pool", None)
    with opener(applied, params, names) if opener is not None else nullcontext():
        if names:
            res = fit_log(fun_map, jac_map, x0, lo, hi, max_nfev=max_nfev, xtol=1e-8,
                          ftol=1e-8, x_scale="jac")
            x = res.x
            jm = jac_map(x)
        else:
            x = x0
            jm = np.zeros((fun(x0).size, 0))
        p = params.from_log(x, names)
        r_all = evaluate(family, applied, p)
    r = r_all[sel]
    rp = prior(x)[0]
    std, corr = _covariance(jm)
    return FitResult(applied, p, names, r_all, float(r @ r), int(r.size),
                     {n: float(s) for n, s in zip(names, std, strict=True)}, corr,
                     float(rp @ rp))


def _prior_rows(family: Family, names: Sequence[str]
                ) -> Callable[[ArrF], tuple[ArrF, ArrF]]:
    """:func:`vfmodel.greybox.priors.prior_rows` of the family's ``priors`` (a mapping name
    -> :class:`~vfmodel.greybox.priors.Prior`, optional; none: no rows): stacked below the
    data residuals they make the fit maximum a posteriori and its Gauss-Newton covariance
    the posterior one."""
    pri = getattr(family, "priors", None) or {}
    return lambda x: prior_rows(x, names, pri)
