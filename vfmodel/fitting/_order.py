"""Automatic order selection for vector fitting: grow where the error is largest, prune
spurious poles, stop at the estimated noise floor or when adding poles stops paying.

Noise floor: the k-th finite difference along frequency of white noise of standard
deviation sigma has variance C(2k, k) sigma^2, while a smooth response contributes little
to high-order differences of densely sampled data. A local median (robust against
resonances and outliers) of the normalised differences gives sigma per frequency; the
smallest estimate over difference orders 2..4 is kept (signal leakage only inflates it).

References
----------
T. Gasser, L. Sroka, C. Jennen-Steinmetz, "Residual variance and residual pattern in
nonlinear regression", Biometrika 73(3), 1986. doi:10.1093/biomet/73.3.625
B. Gustavsen, "Improving the pole relocating properties of vector fitting", IEEE Trans.
Power Delivery 21(3), 2006. doi:10.1109/TPWRD.2005.860281
"""

from __future__ import annotations

from dataclasses import dataclass
from math import comb

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from vfmodel.fitting import _vf_core as core

_NOISE_MARGIN = 1.25  # stop when the weighted error is within this factor of the floor
_MIN_GAIN = 0.10  # a growth step that gains less than 10 % marks the plateau
_GROW_ITERATIONS = 4  # pole relocations per growth step (warm started)
_GROW_TOL = 0.02  # relative error change that ends a growth step early
_DROP_FRACTION = 0.1  # a pole pair contributing < 10 % of the noise RMS is spurious
_EXACT = 1e-11  # relative error treated as an exact fit when no noise is measurable
_WINDOW = 11  # samples of the local median of the noise estimator


@dataclass(frozen=True)
class AutoResult:
    """Outcome of :func:`auto_order`."""

    coef: core.Coefficients
    history: tuple[core.IterationRecord, ...]
    n_iterations: int
    converged: bool
    reason: str
    noise_floor: float


def estimate_noise(prob: core.Problem) -> float:
    """Noise RMS of the weighted responses relative to their RMS (weighted_rel_rms units).

    Difference-based, robust local estimate (see module docstring); 0 when the data has
    too few points to tell.
    """
    wh = prob.wh
    x = np.concatenate([wh.real, wh.imag], axis=1)  # (K, 2M)
    ref = float(np.sqrt(np.mean(np.abs(wh) ** 2)))
    if ref == 0.0:
        return 0.0
    best = np.inf
    for k in (2, 3, 4):
        if x.shape[0] - k < _WINDOW:
            continue
        d = np.abs(np.diff(x, n=k, axis=0)) / np.sqrt(comb(2 * k, k))
        med = np.median(sliding_window_view(d, _WINDOW, axis=0), axis=-1)
        sigma = 1.4826 * med  # (K-k-W+1, 2M) per-component standard deviation
        best = min(best, float(np.mean(sigma**2)))
    if not np.isfinite(best):
        return 0.0
    # complex noise: E|n|^2 = sigma_re^2 + sigma_im^2
    return float(np.sqrt(2.0 * best) / ref)


def _new_poles(
    prob: core.Problem, coef: core.Coefficients, n_pairs: int, w_lo: float
) -> NDArray[np.complex128]:
    """Pole pairs at the frequencies of the largest local maxima of the error."""
    err = np.sum(np.abs(prob.w * (core.evaluate(prob, coef) - prob.h)) ** 2, axis=1)
    e = np.concatenate([[-np.inf], err, [-np.inf]])
    peaks = np.flatnonzero((e[1:-1] > e[:-2]) & (e[1:-1] >= e[2:]))
    order = peaks[np.argsort(err[peaks])[::-1]]
    if order.size < n_pairs:
        seen = set(order.tolist())
        rest = [int(i) for i in np.argsort(err)[::-1] if int(i) not in seen]
        order = np.concatenate([order, np.array(rest, dtype=int)])
    beta = np.maximum(np.abs(prob.s[order[:n_pairs]]), w_lo)
    out: NDArray[np.complex128] = -0.02 * beta + 1j * beta
    return out


def _prune(
    prob: core.Problem, coef: core.Coefficients, threshold: float
) -> core.Coefficients:
    """Drop representatives whose weighted RMS contribution is below ``threshold``."""
    if coef.reps.size <= 1 or threshold <= 0:
        return coef
    contrib = core.pole_contributions(prob, coef)
    keep = contrib >= threshold
    if np.all(keep):
        return coef
    if not np.any(keep):
        keep[int(np.argmax(contrib))] = True
    return core.solve_residues(prob, core.sort_reps(coef.reps[keep]))


def _residual_noise(prob: core.Problem, coef: core.Coefficients) -> float:
    """Noise estimate from the roughness of the fit residual (weighted_rel_rms units)."""
    resid = core.evaluate(prob, coef) - prob.h
    rp = core.Problem(prob.s, resid, prob.w, prob.fit_d, prob.fit_e, prob.dc_index)
    scale = float(np.linalg.norm(prob.w * resid) / max(float(np.linalg.norm(prob.wh)), 1e-300))
    return estimate_noise(rp) * scale


def _greedy_prune(
    prob: core.Problem, coef: core.Coefficients, limit: float, max_trials: int = 60
) -> core.Coefficients:
    """Remove the weakest poles one at a time while the error stays below ``limit``."""
    trials = 0
    while coef.reps.size > 1 and trials < max_trials:
        contrib = core.pole_contributions(prob, coef)
        improved = False
        for j in np.argsort(contrib)[:8]:
            trials += 1
            keep = np.ones(coef.reps.size, bool)
            keep[j] = False
            cand = core.solve_residues(prob, coef.reps[keep])
            if core.weighted_rel_rms(prob, core.evaluate(prob, cand)) <= limit:
                coef, improved = cand, True
                break
        if not improved:
            break
    return coef


def _drop_and_relocate(
    prob: core.Problem, coef: core.Coefficients, stable: bool
) -> tuple[core.Coefficients, float] | None:
    """Remove the weakest representative and run a few fast relocations."""
    if coef.reps.size <= 1:
        return None
    keep = np.ones(coef.reps.size, bool)
    keep[int(np.argmin(core.pole_contributions(prob, coef)))] = False
    res = core.iterate(
        prob,
        coef.reps[keep],
        max_iterations=_GROW_ITERATIONS,
        tol=_GROW_TOL,
        stable=stable,
        precise=False,
    )
    return res.coef, res.weighted_rel_rms


def auto_order(
    prob: core.Problem,
    *,
    w_lo: float,
    w_hi: float,
    spacing: str,
    max_order: int,
    max_iterations: int,
    tol: float,
    stable: bool,
) -> AutoResult:
    """Grow the order from a small start until the noise floor (see module docstring).

    Each growth step adds about a quarter more pole pairs at the largest local maxima of
    the weighted error and runs a few pole relocations from the current poles (warm
    start). The floor is the smaller of the noise estimate (from the data and from the
    roughness of the residual) and, when the error stops improving (a step gains less
    than 10 %), the best error reached. The chosen model is the smallest tried order within
    25 % of the floor; its weakest poles are then removed while the error stays within
    that bound, and the pole relocation is run to convergence.
    """
    noise = estimate_noise(prob)
    data_rms = float(np.sqrt(np.mean(np.abs(prob.wh) ** 2)))
    reps = core.starting_poles(min(max_order, 4), w_lo, w_hi, spacing)
    history: list[core.IterationRecord] = []
    tried: list[tuple[int, float, core.Coefficients]] = []
    n_it = 0
    best_err = np.inf
    why = ""
    stall = n_gain = 0
    while True:
        res = core.iterate(
            prob,
            reps,
            max_iterations=_GROW_ITERATIONS,
            tol=_GROW_TOL,
            stable=stable,
            precise=False,
        )
        n_it += res.n_iterations
        history.extend(res.history)
        coef = _prune(prob, res.coef, _DROP_FRACTION * noise * data_rms)
        err = core.weighted_rel_rms(prob, core.evaluate(prob, coef))
        n = core.n_poles(coef.reps)
        tried.append((n, err, coef))
        noise = min(noise, _residual_noise(prob, coef))
        if err <= _NOISE_MARGIN * max(noise, _EXACT / _NOISE_MARGIN):
            why = "noise"
            break
        # plateau: poles added since the last 10 % gain amount to a quarter of the order
        stall = n - n_gain if err > (1.0 - _MIN_GAIN) * best_err else 0
        if err <= (1.0 - _MIN_GAIN) * best_err:
            n_gain = n
        if stall >= max(4, n_gain // 4):
            why = "plateau"
            break
        best_err = min(best_err, err)
        if n >= max_order:
            why = "max"
            break
        n_pairs = max(1, min((n + 3) // 8, (max_order - n) // 2))
        if max_order - n < 2:
            new = np.array([-w_hi], dtype=complex)
        else:
            new = _new_poles(prob, coef, n_pairs, w_lo)
        reps = core.sort_reps(np.concatenate([coef.reps, new]))
    best_err = min(t[1] for t in tried)
    # at the noise floor the last model is the pick; at a plateau the best error is the floor
    floor = max(noise if why == "noise" else best_err, _EXACT / _NOISE_MARGIN)
    limit = max(_NOISE_MARGIN * floor, tried[-1][1] if why == "noise" else 0.0)
    pick = min((t for t in tried if t[1] <= limit), key=lambda t: (t[0], t[1]), default=None)
    if pick is None:  # only when the maximum order stopped the growth
        pick = min(tried, key=lambda t: (t[1], t[0]))
        limit = pick[1]
    coef = pick[2]
    converged = False
    for round_ in range(6):  # prune, relocate, until nothing more can be removed
        pruned = _greedy_prune(prob, coef, limit)
        if round_ > 0 and pruned.reps.size == coef.reps.size:
            # nothing removable with the poles fixed: drop the weakest pole and let the
            # others move (a few fast relocations) before giving up
            trial = _drop_and_relocate(prob, coef, stable)
            n_it += _GROW_ITERATIONS
            if trial is None or trial[1] > limit:
                break
            pruned = trial[0]
        final = core.iterate(
            prob, pruned.reps, max_iterations=max_iterations, tol=tol, stable=stable
        )
        n_it += final.n_iterations
        history.extend(final.history)
        converged = final.converged
        now = core.weighted_rel_rms(prob, core.evaluate(prob, pruned))
        coef = final.coef if final.weighted_rel_rms <= max(limit, now) else pruned
    err = core.weighted_rel_rms(prob, core.evaluate(prob, coef))
    n = core.n_poles(coef.reps)
    if why == "noise":
        if noise * _NOISE_MARGIN <= _EXACT:
            reason = f"exact fit: weighted relative RMS error {err:.3g} at order {n}"
        else:
            reason = (
                f"order {n}: weighted relative RMS error {err:.3g} is within a factor "
                f"{_NOISE_MARGIN} of the estimated noise floor {noise:.3g}"
            )
    elif why == "plateau":
        reason = (
            f"order {n}: adding poles stopped paying (less than {100 * _MIN_GAIN:.0f} % gain) "
            f"above the noise floor estimate {noise:.3g}; smallest order within a factor "
            f"{_NOISE_MARGIN} of the best error {best_err:.3g} (error {err:.3g})"
        )
    else:
        reason = (
            f"order {n}: maximum order {max_order} reached before the noise floor "
            f"estimate {noise:.3g} (error {err:.3g})"
        )
    return AutoResult(coef, tuple(history), n_it, converged, reason, noise)
