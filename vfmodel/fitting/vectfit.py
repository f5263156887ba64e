"""Public vector fitting: :func:`vector_fit` and its :class:`FitReport`."""

from __future__ import annotations

import functools
import os
import warnings
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from vfmodel._choices import DcMode, Kind, PoleSpacing, Weighting, check_choice
from vfmodel.core.blas import capped_blas
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import FitWarning, InputError
from vfmodel.fitting import _order, _out_of_band, _relocate, _vf_core
from vfmodel.fitting._fit_report import (
    FitReport,
    FitStep,
    _constant_fit,
    _far_from_floor,
    _make_report,
    _to_model,
    fit_errors,
    point_errors,
)
from vfmodel.fitting._fit_setup import (
    _DELAY_EXACT,
    _DELAY_PAYS,
    _RIDGE,
    _anchors,
    _as_frequency_data,
    _check_data,
    _delay,
    _exclude,
    _max_order,
    _phase_turns,
    _pole_bounds,
    _weights,
)

if TYPE_CHECKING:  # pragma: no cover
    import skrf

__all__ = ["FitReport", "FitStep", "data_noise", "fit_errors", "point_errors", "vector_fit"]

_SRC = "vector_fit"
_DELAY_ORDER = 0.9  # delay="auto": the delay is kept only when it cuts the order to this


# ---------------------------------------------------------------------- main entry
@capped_blas
def vector_fit(
    data: FrequencyData | skrf.Network | str | os.PathLike[str],
    order: int | Literal["auto"] = "auto",
    *,
    kind: Kind | None = None,
    weighting: Weighting | NDArray[np.float64] = "auto",
    spacing: PoleSpacing = "log",
    fit_d: bool = True,
    fit_e: bool = False,
    initial_poles: NDArray[np.complex128] | None = None,
    max_iterations: int = 30,
    tol: float = 1e-4,
    max_order: int | None = None,
    enforce_stability: bool = True,
    exclude: NDArray[np.intp] | tuple[int, ...] | None = None,
    dc: DcMode = "enforce",
    target_error: float | None = None,
    delay: float | Literal["auto", "none"] = "none",
    out_of_band_weight: float | None = None,
) -> tuple[RationalModel, FitReport]:
    """Fit a rational model with common poles to every entry of a frequency response.

    Fast relaxed vector fitting: frequencies are scaled to the band edge, starting poles
    are complex pairs log- or linearly spaced over the band, each iteration relocates the
    poles with the relaxed sigma system reduced by QR per response (Deschrijver et al.
    2008) and identifies the residues of all responses in one batched least-squares solve.
    Unstable poles are flipped into the left half plane. With 0 Hz in the data,
    ``fit_d`` and ``dc="enforce"`` the model matches Re H(0) exactly. Data that does not
    change with frequency (an ideal short, a resistive tee) gives a pole-free model, D
    alone.

    Parameters
    ----------
    data : FrequencyData, skrf.Network or path
        Samples of a Z, Y, S or H response of any port count (a path is read by
        :func:`vfmodel.read_spectrum`).
    order : int or "auto"
        Number of poles (each complex pole of a pair counted separately; an odd order has
        one real pole), or "auto": poles are added where the error is largest and spurious
        ones dropped until the residual reaches the estimated noise floor or stops
        improving (see :class:`FitReport` ``order_reason``).
    kind : {"Z", "Y", "S", "H"}, optional
        Representation to fit (data is converted); default: the data's own kind, "S" for a
        skrf.Network.
    weighting : {"auto", "relative", "uniform", "inverse", "inverse-sqrt"} or array
        Least-squares weights. "relative": 1/||H(f)||_F per frequency, so the fit and the
        automatic order aim at the per-point relative error; "uniform": 1; "inverse"
        (alias "inv_abs"): 1/|H_ij|; "inverse-sqrt" ("inv_sqrt_abs"): 1/sqrt|H_ij|.
        "auto" (default): "relative" for Z, Y and H data whose size spans more than a
        decade, otherwise "uniform" (S data: "uniform"). A user array (e.g. 1/standard
        deviation) of shape (n_freq,) per sample, (1, n_out, n_in) per response or
        (n_freq, n_out, n_in) per sample and response.
    spacing : {"log", "lin"}
        Spacing of the starting poles.
    fit_d, fit_e : bool
        Fit the constant term D and the proportional term E.
    initial_poles : array, optional
        Starting poles in rad/s (conjugate pairs listed explicitly); overrides ``order``'s
        starting poles for a fixed order.
    max_iterations : int
        Pole relocations per order.
    tol : float
        Convergence tolerance on max |sigma - 1| and on the relative change of the error.
    max_order : int, optional
        Upper limit of the automatic order (default: what the data supports, at most 200).
    enforce_stability : bool
        Flip unstable poles (default True).
    exclude : sequence of int, optional
        Indices of samples given zero weight (e.g. the spikes found by
        :func:`vfmodel.fitting.artifacts.find_artifacts`); the report's errors still count
        them.
    dc : {"enforce", "fit"}
        With a 0 Hz sample: match Re H(0) exactly ("enforce", default) or weigh it like
        any other sample ("fit").
    target_error : float, optional
        Automatic order: stop at this weighted relative RMS error instead of the
        estimated noise floor.
    delay : float, "auto" or "none"
        Common delay (seconds) taken out before the fit and kept in the model
        (``model.delay``; S and H data only): a long interconnect's phase turns many times
        over the band, which costs about two poles per turn. "auto": when some entry's
        phase turns more than 5 times over the band, the data are fitted with the group
        delay of the largest entry (least-squares phase slope) and without a delay, and the
        delay is kept when its error is within 1.25 times the larger of the other's, its
        noise floor estimate and 1e-6 (reflections advanced
        by a transmission's delay can be harder to fit than the plain data) and it cuts
        the order to at most 0.9 times the plain fit's.

    out_of_band_weight : float, optional
        S data: weight, relative to the median data weight, of out-of-band anchor
        samples (below the band down to 0 Hz the lowest sample, above it the highest)
        that keep the model's out-of-band response of the size of the data; default
        1e-4 (barely felt in the band) while the order is chosen, then 1e-10 (ridge
        likewise scaled) for a last relocation at that order when that cuts the error
        by 1.25x and keeps the model's gain at 0 Hz, at the anchors and of D within 1e-3
        of the anchored fit's (noise-free data; :mod:`vfmodel.fitting._out_of_band`); when
        that error is still above twice the noise margin of a measured noise floor, poles
        are added in the lighter problem while each step gains 10 % and the largest
        singular value on a dense grid stays within the anchored fit's plus its error
        (:func:`vfmodel.fitting._out_of_band.grow`). Larger
        values (0.01-0.1) trade in-band accuracy for out-of-band passivity before an
        enforcement.

    Returns
    -------
    model : RationalModel
        Stable (with ``enforce_stability``) pole-residue model of kind ``kind``.
    report : FitReport

    Raises
    ------
    InputError
        Bad arguments, or data a rational fit cannot represent (fewer than 3 points,
        identically zero or constant data, more poles than the data supports).
    FitError
        The fit produced a non-finite model.

    References
    ----------
    B. Gustavsen, A. Semlyen, IEEE Trans. Power Delivery 14(3), 1999.
    doi:10.1109/61.772353
    B. Gustavsen, IEEE Trans. Power Delivery 21(3), 2006. doi:10.1109/TPWRD.2005.860281
    D. Deschrijver et al., IEEE MWCL 18(6), 2008. doi:10.1109/LMWC.2008.922585
    """
    fd = _as_frequency_data(data, kind)
    constant = _check_data(fd)
    check_choice("spacing", spacing, PoleSpacing)
    check_choice("dc", dc, DcMode)
    if target_error is not None and not (np.isfinite(target_error) and target_error > 0):
        raise InputError("target_error must be positive", found=repr(target_error))
    if not isinstance(max_iterations, int | np.integer) or max_iterations < 1:
        raise InputError("max_iterations must be a positive integer", found=repr(max_iterations))
    if not (np.isfinite(tol) and tol > 0):
        raise InputError("tol must be positive", found=repr(tol))
    w, wname = _weights(fd, weighting)
    if exclude is not None:
        w = _exclude(w, exclude, fd.n_freq)
    if constant:
        return _constant_fit(fd, wname)
    tau = _delay(fd, delay)
    if tau > 0 and delay == "auto":
        # a common delay suits transmission-dominated data; reflections advanced by it are
        # harder to fit: fit both ways and keep the delay only where it pays
        kw: dict[str, Any] = {
              "kind": kind, "weighting": weighting, "spacing": spacing, "fit_d": fit_d,
              "fit_e": fit_e, "initial_poles": initial_poles,
              "max_iterations": max_iterations, "tol": tol, "max_order": max_order,
              "enforce_stability": enforce_stability, "exclude": exclude, "dc": dc,
              "target_error": target_error, "out_of_band_weight": out_of_band_weight}
        with warnings.catch_warnings(record=True):
            warnings.simplefilter("always")
            with_delay = vector_fit(fd, order, delay=tau, **kw)
            without = vector_fit(fd, order, delay="none", **kw)
        e1, e0 = with_delay[1].weighted_rel_rms_error, without[1].weighted_rel_rms_error
        floor = max(e0, without[1].noise_floor or 0.0, _DELAY_EXACT)
        # the delay must pay in order: one that leaves the order as it is brings only
        # risk (the rational part then carries exp(+s tau) out of band: an 8-port PDN
        # with a 6 ps 'delay' fitted 94 poles vs 93 without and sigma(D) = 27 vs 1.15)
        cuts = with_delay[0].n_poles <= _DELAY_ORDER * without[0].n_poles
        pick = with_delay if e1 <= _DELAY_PAYS * floor and cuts else without
        for note in pick[1].notes:
            warnings.warn(note, FitWarning, stacklevel=3)
        return pick
    if tau > 0:  # fit the response advanced by the delay; the model carries it
        data_fd = fd
        fd = fd.with_values(fd.values * np.exp(2j * np.pi * fd.freq_hz * tau)[:, None, None])
    has_dc = bool(fd.freq_hz[0] == 0.0)
    n_extra = int(bool(fit_d)) + int(bool(fit_e))
    limit = _max_order(fd.n_freq, has_dc, n_extra)
    omega = fd.omega
    omega_scale = float(omega[-1])
    h = fd.values.reshape(fd.n_freq, -1).copy()
    if has_dc:
        h[0] = h[0].real  # a real model is real at s = 0
    prob = _vf_core.Problem(
        s=np.asarray(1j * omega / omega_scale, dtype=complex),
        h=h,
        w=w,
        fit_d=bool(fit_d),
        fit_e=bool(fit_e),
        dc_index=0 if has_dc and dc == "enforce" else None,
        pole_bounds=_pole_bounds(fd, omega_scale),
        ridge=_RIDGE if fd.kind == "S" else 0.0,
        anchors=(_anchors(fd, h, w, omega_scale, out_of_band_weight)
                 if fd.kind == "S" else None),
    )
    # S data: once the poles are found, a last relocation with the lighter out-of-band
    # control (vfmodel.fitting._out_of_band)
    lighter: _order.Finish | None = None
    if fd.kind == "S" and out_of_band_weight is None:
        lighter = functools.partial(_out_of_band.lighter, prob, n_ports=fd.n_out,
                                    max_iterations=max_iterations, tol=tol,
                                    stable=enforce_stability)
    positive = omega[omega > 0] / omega_scale
    w_lo, w_hi = float(positive[0]), 1.0
    if order == "auto":
        if initial_poles is not None:
            raise InputError("initial_poles cannot be combined with order='auto'")
        cap = min(limit, 200) if max_order is None else min(int(max_order), limit)
        if cap < 2:
            raise InputError(
                "too few frequency points for an automatic fit",
                source=fd.source or _SRC,
                found=f"{fd.n_freq} points",
                expected="enough points for at least 2 poles",
            )
        auto = _order.auto_order(
            prob,
            w_lo=w_lo,
            w_hi=w_hi,
            spacing=spacing,
            max_order=cap,
            max_iterations=max_iterations,
            tol=tol,
            stable=enforce_stability,
            target=target_error,
            margin=_order.RELATIVE_MARGIN if wname == "relative" else _order.NOISE_MARGIN,
            plateau_margin=(_order.RELATIVE_MARGIN if wname == "relative"
                            else _order.PLATEAU_MARGIN),
            # a response whose phase turns many times needs about two poles per turn:
            # no plateau is declared below that order
            min_order=min(cap, int(2 * _phase_turns(fd)) + 4),
            finish=lighter,
            # not with out-of-band anchors stronger than the default (fit --passive's retry
            # for a bounded model): they cap the error themselves, and WEST Bridge's refit at
            # 0.1 grew from 4 to 21 poles at 2.6e-4, whose enforcement took 410 s of the
            # retries' time and left the relocation retry (7.6e-7) no time
            extend=out_of_band_weight is None,
        )
        coef, history, n_it, converged = auto.coef, auto.history, auto.n_iterations, auto.converged
        reason, noise, hit_max = auto.reason, auto.noise_floor, auto.hit_max
        # a noise-free S fit that stopped at the anchored cap: more poles with the
        # lighter out-of-band control (vfmodel.fitting._out_of_band.grow)
        grown = None if lighter is None or target_error is not None else _out_of_band.grow(
            prob, auto.prob, coef, fd.n_out, noise=noise,
            margin=_order.RELATIVE_MARGIN if wname == "relative" else _order.NOISE_MARGIN,
            w_lo=w_lo, max_order=cap, max_iterations=max_iterations, tol=tol,
            stable=enforce_stability)
        if grown is not None:
            n_before = _vf_core.n_poles(coef.reps)
            prob, coef = grown[0], grown[1].coef
            n_it += grown[1].n_iterations
            history = (*history, *grown[1].history)
            converged = grown[1].converged
            reason = (f"order {_vf_core.n_poles(coef.reps)}: grown from {n_before} poles with "
                      f"the lighter out-of-band control (the anchored growth stopped at its "
                      f"cap above the noise floor estimate {noise:.3g}; weighted relative "
                      f"RMS error {grown[1].weighted_rel_rms:.3g})")
        elif auto.prob is not None:  # the lighter relocation was kept
            prob = auto.prob
    else:
        if isinstance(order, bool) or not isinstance(order, int | np.integer):
            raise InputError("order must be a positive integer or 'auto'", found=repr(order))
        n = int(order)
        if initial_poles is not None:
            reps = _reps_from_user(initial_poles, omega_scale)
            n = _vf_core.n_poles(reps)
        else:
            reps = None
        if n < 1:
            raise InputError("order must be at least 1", found=str(n))
        if n > limit:
            raise InputError(
                f"order {n} needs more frequency points than the data has",
                source=fd.source or _SRC,
                found=f"{fd.n_freq} points ({2 * fd.n_freq - int(has_dc)} real equations)",
                expected=f"order <= {limit} for these data",
            )
        if reps is None:
            reps = _vf_core.starting_poles(n, w_lo, w_hi, spacing)
        res = _relocate.iterate(
            prob, reps, max_iterations=max_iterations, tol=tol, stable=enforce_stability
        )
        coef, history, n_it, converged = res.coef, res.history, res.n_iterations, res.converged
        took = None if lighter is None else lighter(coef)
        if took is not None:  # the lighter control's relocation at this order is kept
            prob, last = took
            coef, converged = last.coef, last.converged
            history, n_it = (*history, *last.history), n_it + last.n_iterations
        reason, noise = f"order {n} given", None
    model = _to_model(coef, fd, omega_scale, fit_d=bool(fit_d), fit_e=bool(fit_e))
    fitted = fd  # the data the rational part fitted (advanced by the delay, if any)
    if tau > 0:
        fd, model = data_fd, RationalModel(model.poles, model.residues, model.d, model.e,
                                           model.kind, model.z0, delay=tau)
    report = _make_report(
        model, fd, prob, coef, n_it, converged, reason, noise, history, wname
    )
    if order == "auto":
        report = _far_from_floor(report, fitted, limit=cap, hit_max=hit_max, delay=tau)
    for note in report.notes:
        warnings.warn(note, FitWarning, stacklevel=3)
    if not converged:
        warnings.warn(
            f"vector fitting did not converge in {max_iterations} iterations per order "
            f"(relative RMS error {report.rel_rms_error:.3g}); raise max_iterations or "
            "change the order",
            FitWarning,
            stacklevel=3,
        )
    return model, report


def _reps_from_user(poles: Any, omega_scale: float) -> NDArray[np.complex128]:
    p = np.atleast_1d(np.asarray(poles, dtype=complex))
    if p.ndim != 1 or p.size == 0 or not np.all(np.isfinite(p)):
        raise InputError("initial_poles must be a non-empty 1-D array of finite poles")
    # reuse the model's pairing check (raises InputError for unpaired poles)
    m = RationalModel(poles=p, residues=np.zeros((p.size, 1, 1), complex), kind="H")
    reps = m.poles[(m.poles.imag >= 0)] / omega_scale
    return _vf_core.sort_reps(reps)


def data_noise(data: FrequencyData) -> float | None:
    """Relative noise level of a spectrum as the automatic order sees it (the estimate of
    ``order="auto"``, weights ``1/||H(f)||``); None below 16 points or for all-zero data."""
    f = data.freq_hz
    norm = np.linalg.norm(data.values.reshape(data.n_freq, -1), axis=1)
    if data.n_freq < 16 or float(np.max(norm)) <= 0:
        return None
    w = 1.0 / np.maximum(norm, 1e-12 * float(np.max(norm)))
    prob = _vf_core.Problem(1j * f / max(f[-1], 1e-300) + 0j,
                            data.values.reshape(data.n_freq, -1), w[:, None],
                            True, False, None)
    return float(_order.estimate_noise(prob))
