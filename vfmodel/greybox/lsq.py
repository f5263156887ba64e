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

__all__ = ["Z95", "LogCovariance", "LogFit", "fit_log", "log_covariance", "log_interval",
           "log_start", "widen_interval"]

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


COMPRESS_MIN_WORK = 5e7
"""``compress=None`` compresses (:class:`_Compressed`) when ``m n^2`` of the ``m x n``
Jacobian reaches this (the solver's SVD then costs ~25 ms or more per step) and
``m >= 10 n``. Below it the SVD is cheap and the compressed steps, equal only to
rounding, would merely perturb the path of fits that end at their evaluation limit."""
_LOG_SPAN_MAX = 50.0  # an interval beyond e^50 (5e21x) either way states no bound
Z95 = 1.959964  # two-sided 95 % quantile of the standard normal distribution


def _last_value(g: Callable[[ArrF], ArrF]) -> Callable[[ArrF], ArrF]:
    """``g`` remembering its last argument and value (the basis of :class:`_Compressed`
    takes the Jacobian at the point where the solver asks for it next)."""
    memo: dict[bytes, ArrF] = {}

    def h(x: ArrF) -> ArrF:
        k = x.tobytes()
        if k not in memo:
            memo.clear()
            memo[k] = g(x)
        return memo[k]

    return h


class _Compressed:
    """A long residual ``f`` (``m`` rows) seen through ``2n + 1`` coordinates that keep
    everything the trust-region reflective solver reads: the cost ``|f|^2`` at every
    point, and ``J^T J`` and ``J^T f`` at every point where it asks for the Jacobian.

    ``T`` is an orthonormal basis of the first Jacobian's columns (one QR, at the solver's
    starting point). At any ``x`` the compressed residual is ``[T^T f, |f - T T^T f|, 0]``;
    its norm is ``|f|``. Where the solver asks for the Jacobian (an accepted point, whose
    residual it already holds) the compressed Jacobian is ``[T^T J; e^T J; S]``, with ``e``
    the unit direction of ``f``'s part outside ``T`` and ``S`` the symmetric square root of
    ``P^T P``, ``P = (I - T T^T - e e^T) J``: then ``Jc^T Jc = J^T J`` and
    ``Jc^T fc = J^T f`` exactly (``f`` has no part along ``P``'s coordinates), so every
    step is the step of the full problem. Cost per Jacobian: three ``m x n x n`` products
    instead of the solver's SVD of the ``m x n`` matrix (independent bench 104's joint
    stage: ~110,000 rows, 36 columns, 0.2 s per SVD). Problems with ``m n^2`` below
    ``min_work`` (or fewer than 10 rows per parameter) are passed through unchanged.
    """

    def __init__(self, fun: Callable[[ArrF], ArrF], jac: Callable[[ArrF], ArrF],
                 min_work: float) -> None:
        self._fun, self._jac = fun, jac
        self._min_work = min_work
        self._t: ArrF | None = None
        self._on: bool | None = None
        self._last: tuple[bytes, ArrF] | None = None

    def fun(self, x: ArrF) -> ArrF:
        f = self._fun(x)
        if self._on is None:  # the solver's starting point: decide, and take the basis
            self._on = f.size >= 10 * x.size and f.size * x.size**2 >= self._min_work
            if self._on:
                self._t = np.linalg.qr(self._jac(x))[0]
        if not self._on:
            return f
        t = self._t
        assert t is not None
        c = t.T @ f
        r = f - t @ c
        r -= t @ (t.T @ r)  # second Gram-Schmidt pass: r orthogonal to T
        rest = float(np.linalg.norm(r))
        self._last = (x.tobytes(), r / rest if rest > 0 else np.zeros_like(r))
        return np.concatenate([c, [rest], np.zeros(t.shape[1])])

    def jac(self, x: ArrF) -> ArrF:
        if not self._on:
            return self._jac(x)
        if self._last is None or self._last[0] != x.tobytes():
            self.fun(x)
        assert self._last is not None and self._t is not None
        e, t = self._last[1], self._t
        j = self._jac(x)
        a = t.T @ j
        b = e @ j
        p = j - t @ a - np.outer(e, b)
        w, v = np.linalg.eigh(p.T @ p)
        sq = (v * np.sqrt(np.clip(w, 0.0, None))) @ v.T
        return np.vstack([a, b[None, :], sq])


def fit_log(fun: Callable[[ArrF], ArrF], jac: Callable[[ArrF], ArrF], x0: ArrF, lo: ArrF,
            hi: ArrF, *, max_nfev: int, xtol: float, ftol: float, gtol: float = 1e-8,
            x_scale: Any = None, compress: bool | None = False) -> LogFit:
    """Minimise ``|fun(x)|^2`` for ``lo <= x <= hi`` (trust-region reflective) from ``x0``.

    ``jac(x)`` is ``d fun / dx``; ``x_scale`` ``None`` (SciPy's default) or ``"jac"``.
    ``compress=True`` hands the solver the equivalent short system of
    :class:`_Compressed`; ``None``: when the solver's SVD is costly
    (:data:`COMPRESS_MIN_WORK`). The identification stages use ``None``: only the joint
    stage is compressed (~110,000 waveform residuals, 36 parameters: 31.7 -> 12.8 s on
    independent bench 104, loaded machine); the detective's refits do not (the SVD is not
    their cost: 62.6 vs 65.9 s CPU on pmsm_fixture without/with)."""
    kw: dict[str, Any] = {} if x_scale is None else {"x_scale": x_scale}
    if compress is not False:
        c = _Compressed(_last_value(fun), _last_value(jac),
                        COMPRESS_MIN_WORK if compress is None else 0.0)
        fun, jac = c.fun, c.jac
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


def _log_gradient(params: ParamSet, names: tuple[str, ...],
                  quantity: Callable[[ParamSet], float]) -> ArrF:
    """``d log quantity / d log p`` of ``names`` by central differences of step 1e-4 (0
    where the quantity is not positive on either side)."""
    x0 = params.to_log(names)
    g = np.zeros(len(names))
    for j in range(len(names)):
        xp, xm = x0.copy(), x0.copy()
        xp[j] += 1e-4
        xm[j] -= 1e-4
        qp = quantity(params.from_log(xp, names))
        qm = quantity(params.from_log(xm, names))
        g[j] = (np.log(qp) - np.log(qm)) / 2e-4 if qp > 0 and qm > 0 else 0.0
    return g


def _quadratic(a: ArrF, cov: ArrF, b: ArrF) -> float | None:
    """``a^T cov b`` over the entries where ``a`` or ``b`` is not ~0; None when ``cov`` is
    not finite there (a direction the data do not bound)."""
    used = (np.abs(a) > 1e-9) | (np.abs(b) > 1e-9)
    sub = cov[np.ix_(used, used)]
    if not np.all(np.isfinite(sub)):
        return None
    return float(a[used] @ sub @ b[used])


def log_interval(params: ParamSet, report: LogCovariance,
                 quantity: Callable[[ParamSet], float],
                 level_z: float = Z95, *,
                 anchor: Callable[[ParamSet], float] | None = None,
                 anchor_tau: float = 0.0,
                 anchor_report: LogCovariance | None = None) -> dict[str, float | None]:
    """Value and 95 % interval of a positive derived ``quantity(params)`` from a fit's
    covariance of ``log p`` (``report``: e.g. an identification ``StageReport``), by the
    delta method in log space: ``var log q = g^T C g`` with ``g = d log q / d log p`` by
    central differences of step 1e-4.

    ``anchor`` and ``anchor_tau`` add a structural model error (:mod:`.model_error`): the
    log of the positive quantity ``anchor`` (e.g. the common-mode bearing transfer at
    100 kHz) is off by a zero-mean error of standard deviation ``anchor_tau`` that the noise
    covariance does not hold. It reaches ``q`` through the posterior regression of
    ``log q`` on ``log anchor``: ``var log q += (beta anchor_tau)^2``,
    ``beta = g^T C g_a / g_a^T C g_a`` (1 for the anchor itself, 0 for a quantity the
    anchor does not inform). ``anchor_report`` (default ``report``): the covariance the
    regression is taken on, e.g. the conditional covariance of the stage whose fit carries
    the error (the parameters that stage moves to meet the biased level), where ``report``
    also holds the uncertainty of parameters held fixed in that stage.

    Returns ``value``, ``lo``, ``hi`` and ``std_log`` (``lo``/``hi``/``std_log`` ``None``
    when the data do not bound it: an infinite variance); with ``anchor`` also
    ``std_log_noise`` (without the model error) and ``model_error_log`` (``beta tau``).
    """
    q0 = float(quantity(params))
    extra: dict[str, float | None] = {}
    if anchor is not None:
        extra = {"std_log_noise": None, "model_error_log": None}
    if report.cov_log is None or q0 <= 0:
        return {"value": q0, "lo": None, "hi": None, "std_log": None, **extra}
    # names of the report that ``params`` holds (a joint stage also has per-speed copies)
    keep = [k for k, n in enumerate(report.names) if n in params]
    names = tuple(report.names[k] for k in keep)
    g = _log_gradient(params, names, quantity)
    cov = report.cov_log[np.ix_(keep, keep)]
    v = _quadratic(g, cov, g)
    if v is None:
        return {"value": q0, "lo": None, "hi": None, "std_log": None, **extra}
    var = max(v, 0.0)
    if anchor is not None:
        extra["std_log_noise"] = float(np.sqrt(var))
        beta = 0.0
        basis = report if anchor_report is None else anchor_report
        if anchor_tau > 0 and float(anchor(params)) > 0 and basis.cov_log is not None:
            kb = [k for k, n in enumerate(basis.names) if n in params]
            nb = tuple(basis.names[k] for k in kb)
            cb = basis.cov_log[np.ix_(kb, kb)]
            gq = g if nb == names else _log_gradient(params, nb, quantity)
            ga = _log_gradient(params, nb, anchor)
            vaa, vqa = _quadratic(ga, cb, ga), _quadratic(gq, cb, ga)
            if vaa is not None and vqa is not None and vaa > 0:
                beta = vqa / vaa
        extra["model_error_log"] = abs(beta) * anchor_tau
        var += (beta * anchor_tau) ** 2
    sd = float(np.sqrt(var))
    return {"value": q0, **_bounds(q0, sd, level_z), "std_log": sd, **extra}


def _bounds(q0: float, sd: float, level_z: float) -> dict[str, float | None]:
    """``lo``/``hi`` of ``q0 exp(-+level_z sd)``; None beyond :data:`_LOG_SPAN_MAX` (no
    bound the data give; exp would overflow)."""
    if level_z * sd > _LOG_SPAN_MAX:
        return {"lo": None, "hi": None}
    return {"lo": q0 * float(np.exp(-level_z * sd)), "hi": q0 * float(np.exp(level_z * sd))}


def lower_bound_only(interval: dict[str, float | None], tau_interval: dict[str, float | None],
                     record_s: float) -> dict[str, Any]:
    """The interval of a DC resistance that a record of ``record_s`` seconds sees only
    through a discharge of time constant ``tau`` (``tau_interval``, e.g. of
    :func:`vfmodel.greybox.bearing.film_time_constant`): when the corner ``1 / (2 pi tau)``
    may lie below the record's resolution ``1 / record_s`` (``2 pi tau_hi > record_s``, or
    ``tau`` not bounded), a larger resistance only moves that corner further below the
    band, so the record bounds the resistance from below only: ``hi`` becomes None and
    ``bound`` says ``"lower"`` (else ``"two-sided"``); ``time_constant_s`` holds the
    interval of ``tau`` and ``record_s`` the record's duration."""
    hi_tau = tau_interval.get("hi")
    resolved = hi_tau is not None and 2.0 * np.pi * float(hi_tau) <= record_s
    out: dict[str, Any] = {**interval, "bound": "two-sided" if resolved else "lower",
           "time_constant_s": {k: tau_interval.get(k) for k in ("value", "lo", "hi")},
           "record_s": float(record_s)}
    if not resolved:
        out["hi"] = None
    return out


def widen_interval(interval: dict[str, float | None], shift_log: float,
                   level_z: float = Z95) -> dict[str, float | None]:
    """``interval`` (:func:`log_interval`) with a structural shift: ``std_log`` combined in
    quadrature with ``shift_log`` (the log of how far the quantity moved between two fits
    of the same data that differ in what they hold fixed, e.g. the stage-wise and the joint
    identification), ``lo``/``hi`` from it; the shift is written as ``refit_shift_log``. An
    interval without bound stays without; an infinite shift (the quantity vanished in one
    fit) leaves none (``refit_shift_log`` null)."""
    if not np.isfinite(shift_log):
        return {**interval, "lo": None, "hi": None, "std_log": None, "refit_shift_log": None}
    out = {**interval, "refit_shift_log": float(shift_log)}
    sd0, q0 = interval.get("std_log"), interval.get("value")
    if sd0 is None or q0 is None or interval.get("lo") is None:
        return out
    sd = float(np.hypot(sd0, shift_log))
    return {**out, **_bounds(q0, sd, level_z), "std_log": sd}
