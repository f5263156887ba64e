"""Bounded least squares over log-scaled parameters: the one fitter of the grey-box model.

Every fit of network parameters (the identification stages, :func:`.identify.fit_stage`; the
detective's refits, :func:`vfmodel.detective.fit.refit`; the calibration proxy of the
concealed benches) varies ``x = log(value)`` inside the physical bounds
``[log lower, log upper]`` with the trust-region reflective method, and reports the
Gauss-Newton covariance of ``log p`` from the Jacobian at the optimum. Callers differ only in
their residual, Jacobian and stopping tolerances, which are arguments here.

References
----------
M. A. Branch, T. F. Coleman, Y. Li, "A subspace, interior, and conjugate gradient method for
large-scale bound-constrained minimization problems", SIAM J. Sci. Comput. 21(1), 1-23,
1999. doi:10.1137/S1064827595289108
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from vfmodel.greybox.params import ParamSet

__all__ = ["LogCovariance", "LogFit", "fit_log", "log_covariance", "log_interval", "log_start"]

ArrF = NDArray[np.float64]


@dataclass(frozen=True)
class LogFit:
    """Result of :func:`fit_log`: the optimum ``x`` (log values), function evaluations and
    the solver status (> 0: converged by a tolerance, 0: ``max_nfev`` reached)."""

    x: ArrF
    nfev: int
    status: int


def log_start(params: ParamSet, names: Sequence[str]) -> tuple[ArrF, ArrF, ArrF]:
    """``(x0, lo, hi)``: log values of ``names`` clipped to their log bounds, and the bounds."""
    lo, hi = params.log_bounds(names)
    return np.clip(params.to_log(names), lo, hi), lo, hi


def fit_log(fun: Callable[[ArrF], ArrF], jac: Callable[[ArrF], ArrF], x0: ArrF, lo: ArrF,
            hi: ArrF, *, max_nfev: int, xtol: float, ftol: float, gtol: float = 1e-8,
            x_scale: Any = None) -> LogFit:
    """Minimise ``|fun(x)|^2`` for ``lo <= x <= hi`` (trust-region reflective) from ``x0``.

    ``jac(x)`` is ``d fun / dx``; ``x_scale`` ``None`` (SciPy's default) or ``"jac"``."""
    kw: dict[str, Any] = {} if x_scale is None else {"x_scale": x_scale}
    res = least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf", max_nfev=max_nfev,
                        xtol=xtol, ftol=ftol, gtol=gtol, **kw)
    return LogFit(np.asarray(res.x, dtype=float), int(res.nfev), int(res.status))


def log_covariance(jac: ArrF, scale: float = 1.0, rcond: float = 1e-10) -> ArrF:
    """Covariance of ``log p``: ``scale (J^T J)^+`` (SVD pseudo-inverse, singular values
    below ``rcond`` times the largest dropped); a parameter in a direction the data do not
    see at all gets an infinite variance on its diagonal."""
    n = jac.shape[1]
    if jac.size == 0:
        return np.zeros((n, n))
    _, s, vt = np.linalg.svd(jac, full_matrices=False)
    keep = s > s[0] * rcond
    cov = (vt[keep].T / s[keep] ** 2) @ vt[keep] * scale
    if np.any(~keep):
        null = np.sum(vt[~keep] ** 2, axis=0) > 1e-6
        cov[null, null] = np.inf
    return np.asarray(cov, dtype=float)


class LogCovariance(Protocol):
    """What :func:`log_interval` reads of a fit report."""

    @property
    def names(self) -> tuple[str, ...]: ...

    @property
    def cov_log(self) -> NDArray[np.float64] | None: ...


def log_interval(params: ParamSet, report: LogCovariance,
                 quantity: Callable[[ParamSet], float],
                 level_z: float = 1.959964) -> dict[str, float | None]:
    """Value and 95 % interval of a positive derived ``quantity(params)`` from a fit's
    covariance of ``log p`` (``report``: e.g. an identification ``StageReport``), by the
    delta method in log space: ``var log q = g^T C g`` with ``g = d log q / d log p`` by
    central differences of step 1e-4.

    Returns ``value``, ``lo``, ``hi`` and ``std_log`` (``lo``/``hi``/``std_log`` ``None``
    when the data do not bound it: an infinite variance).
    """
    q0 = float(quantity(params))
    if report.cov_log is None or q0 <= 0:
        return {"value": q0, "lo": None, "hi": None, "std_log": None}
    # names of the report that ``params`` holds (a joint stage also has per-speed copies)
    keep = [k for k, n in enumerate(report.names) if n in params]
    names = tuple(report.names[k] for k in keep)
    x0 = params.to_log(names)
    g = np.zeros(len(names))
    for j in range(len(names)):
        xp, xm = x0.copy(), x0.copy()
        xp[j] += 1e-4
        xm[j] -= 1e-4
        qp = quantity(params.from_log(xp, names))
        qm = quantity(params.from_log(xm, names))
        g[j] = (np.log(qp) - np.log(qm)) / 2e-4 if qp > 0 and qm > 0 else 0.0
    cov = report.cov_log[np.ix_(keep, keep)]
    used = np.abs(g) > 1e-9
    if not np.all(np.isfinite(cov[np.ix_(used, used)])):
        return {"value": q0, "lo": None, "hi": None, "std_log": None}
    var = float(g[used] @ cov[np.ix_(used, used)] @ g[used])
    sd = float(np.sqrt(max(var, 0.0)))
    return {"value": q0, "lo": q0 * float(np.exp(-level_z * sd)),
            "hi": q0 * float(np.exp(level_z * sd)), "std_log": sd}
