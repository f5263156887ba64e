"""Public vector fitting: :func:`vector_fit` and its :class:`FitReport`."""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from vfmodel._choices import DcMode, Kind, PoleSpacing, Weighting, check_choice
from vfmodel.core.frequency_data import FrequencyData, as_frequency_data
from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import FitError, FitWarning, InputError
from vfmodel.fitting import _order, _vf_core

if TYPE_CHECKING:  # pragma: no cover
    import skrf

__all__ = ["FitReport", "FitStep", "vector_fit"]

_SRC = "vector_fit"


@dataclass(frozen=True)
class FitStep:
    """One pole-relocation iteration of the fit.

    ``order`` counts every pole (each complex pole of a conjugate pair separately);
    ``weighted_rel_rms_error`` = ||W (H_model - H)||_F / ||W H||_F at that iteration;
    ``sigma_deviation`` = max |sigma - 1| (0 when the poles no longer move).
    """

    order: int
    weighted_rel_rms_error: float
    sigma_deviation: float


@dataclass(frozen=True)
class FitReport:
    """What :func:`vector_fit` did and how well the model matches the data.

    Attributes
    ----------
    order : int
        Number of poles, each complex pole of a conjugate pair counted separately
        (the length of ``model.poles``).
    n_iterations : int
        Pole-relocation iterations run in total (all orders tried).
    rms_error : float
        sqrt(mean |H_model - H_data|^2) over all frequencies and entries (unweighted).
    rel_rms_error : float
        ||H_model - H_data||_F / ||H_data||_F over all frequencies and entries
        (CONTRACT section 4).
    weighted_rel_rms_error : float
        The same with the fitting weights: ||W (H_model - H)||_F / ||W H||_F.
    max_abs_error : float
        max |H_model - H_data|.
    converged : bool
        The last pole relocation met the convergence test.
    order_reason : str
        Why this order (given, or how the automatic selection stopped).
    noise_floor : float or None
        Estimated noise level of the data in the units of ``weighted_rel_rms_error``
        (RMS of the noise of W H divided by the RMS of W H); None when not estimated.
    history : tuple of FitStep
        Every pole-relocation iteration in order.
    weighting : str
        The weighting used ("user" for an array; "auto" is resolved to what it chose).
    kind : str
        Representation fitted (Z, Y, S or H).
    point_rel_rms_error, point_rel_max_error : float
        Per-point relative error e(f) = ||H_model(f) - H_data(f)||_F / ||H_data(f)||_F:
        its RMS over the frequencies and its maximum (what a user judging an impedance
        point by point sees, e.g. the MAPE of |Z|).
    notes : tuple of str
        Warnings about the fit (also raised as :class:`~vfmodel.errors.FitWarning`), e.g.
        an error that stays far above the noise floor and why.
    """

    order: int
    n_iterations: int
    rms_error: float
    rel_rms_error: float
    weighted_rel_rms_error: float
    max_abs_error: float
    converged: bool
    order_reason: str
    noise_floor: float | None
    history: tuple[FitStep, ...]
    weighting: str
    kind: str
    point_rel_rms_error: float = 0.0
    point_rel_max_error: float = 0.0
    notes: tuple[str, ...] = ()

    def _repr_html_(self) -> str:
        """Compact summary in Jupyter (:mod:`vfmodel.report.notebook`)."""
        from vfmodel.report.notebook import fit_report_html

        return fit_report_html(self)

    def plot(self, ax: Any = None) -> Any:
        """Error of every pole-relocation iteration (matplotlib imported now); the axes."""
        from vfmodel.report.notebook import fit_report_plot

        return fit_report_plot(self, ax)


# ---------------------------------------------------------------------- input handling
def _as_frequency_data(data: Any, kind: Kind | None) -> FrequencyData:
    if kind is not None:
        check_choice("kind", kind, Kind)
    return as_frequency_data(data, kind, source=_SRC)


_ALIASES = {"inverse": "inv_abs", "inverse-sqrt": "inv_sqrt_abs"}
_DECADE_SPAN = 10.0  # "auto": relative weighting when ||H(f)|| spans more than this factor


def _resolve_weighting(fd: FrequencyData, weighting: str) -> str:
    """Name of the weighting "auto" stands for (see :data:`vfmodel._choices.Weighting`)."""
    if weighting != "auto":
        return _ALIASES.get(weighting, weighting)
    if fd.kind == "S":
        return "uniform"
    norm = np.linalg.norm(fd.values.reshape(fd.n_freq, -1), axis=1)
    top = float(np.max(norm))
    low = float(np.min(norm))
    return "relative" if low <= 0 or top / low > _DECADE_SPAN else "uniform"


def _weights(fd: FrequencyData, weighting: Any) -> tuple[NDArray[np.float64], str]:
    """Weights (K, Mw) and the name of the weighting."""
    h = fd.values.reshape(fd.n_freq, -1)
    if isinstance(weighting, str):
        check_choice("weighting", weighting, Weighting)
        weighting = _resolve_weighting(fd, weighting)
        if weighting == "uniform":
            return np.ones((fd.n_freq, 1)), weighting
        if weighting == "relative":
            norm = np.linalg.norm(h, axis=1)
            norm = np.maximum(norm, 1e-12 * float(np.max(norm)))
            return (1.0 / np.where(norm > 0, norm, 1.0))[:, None], weighting
        mag = np.abs(h)
        floor = 1e-12 * max(float(np.max(mag)), 1e-300)
        mag = np.maximum(mag, floor)
        w = 1.0 / mag if weighting == "inv_abs" else 1.0 / np.sqrt(mag)
        return w, weighting
    w = np.asarray(weighting, dtype=float)
    if w.shape == (fd.n_freq,):
        w = w[:, None]
    elif w.shape == (1, fd.n_out, fd.n_in):  # per response, every frequency
        w = np.repeat(w.reshape(1, -1), fd.n_freq, axis=0)
    elif w.shape == fd.values.shape:
        w = w.reshape(fd.n_freq, -1)
    else:
        raise InputError(
            "weighting array has the wrong shape",
            source=_SRC,
            place="weighting",
            found=str(w.shape),
            expected=f"{(fd.n_freq,)}, {(1, fd.n_out, fd.n_in)} or {fd.values.shape}",
        )
    if not np.all(np.isfinite(w)) or np.any(w < 0) or not np.any(w > 0):
        raise InputError(
            "weights must be finite, non-negative and not all zero",
            source=_SRC,
            place="weighting",
        )
    return w, "user"


def _exclude(w: NDArray[np.float64], exclude: Any, n_freq: int) -> NDArray[np.float64]:
    idx = np.asarray(exclude)
    if idx.size == 0:
        return w
    if idx.ndim != 1 or not np.issubdtype(idx.dtype, np.integer) or np.any(
        (idx < 0) | (idx >= n_freq)
    ):
        raise InputError(
            "exclude must be sample indices",
            source=_SRC,
            place="exclude",
            found=repr(exclude)[:80],
            expected=f"integers in [0, {n_freq})",
        )
    w = w.copy()
    w[idx] = 0.0
    if np.unique(idx).size > n_freq - 3:
        raise InputError("exclude leaves fewer than 3 samples", source=_SRC, place="exclude")
    return w


def _check_data(fd: FrequencyData) -> bool:
    """Reject data no rational fit can represent; True for frequency-independent data
    (fitted by D alone, without poles)."""
    src = fd.source or _SRC
    if fd.n_freq < 3:
        raise InputError(
            "too few frequency points for a rational fit",
            source=src,
            found=f"{fd.n_freq} point(s)",
            expected="at least 3 frequency points",
        )
    if fd.freq_hz[-1] <= 0:
        raise InputError("no positive frequency", source=src)
    h = fd.values.reshape(fd.n_freq, -1)
    scale = float(np.max(np.abs(h)))
    if scale == 0.0:  # zero everywhere (Z of a short, Y of an open): D = 0
        return True
    spread = float(np.max(np.abs(h - h.mean(axis=0, keepdims=True))))
    if spread > _CONSTANT * scale:
        return False
    if float(np.max(np.abs(h.mean(axis=0).imag))) > _CONSTANT * scale:
        raise InputError(
            "the data is a constant that is not real; no real rational model has a "
            "frequency-independent complex response",
            source=src,
            expected="a real constant or a frequency-dependent response",
        )
    return True


_CONSTANT = 1e-9  # relative spread over frequency below which the data is a constant


_POLE_SPAN = (10.0, 100.0)  # S models: real poles within [f_lo / 10, 100 f_hi]


_RIDGE = 1e-7  # S fits: Tikhonov weight of the residue solve (see _vf_core.Problem)


_ANCHOR_BELOW = (0.5, 0.2, 0.05, 0.0)  # anchor frequencies / lowest data frequency
_ANCHOR_ABOVE = (2.0, 5.0, 20.0, 100.0)  # anchor frequencies / highest data frequency
_ANCHOR_WEIGHT = 1e-4  # anchor weight relative to the median data weight


def _anchors(
    fd: FrequencyData,
    h: NDArray[np.complex128],
    w: NDArray[np.float64],
    omega_scale: float,
    rel_weight: float | None,
) -> tuple[NDArray[np.complex128], NDArray[np.complex128], float] | None:
    """Out-of-band anchors of S fits (see :class:`_vf_core.Problem`): below the band
    (down to 0 Hz unless the data has it) the lowest sample, above it the highest."""
    if w.shape[1] != 1 or rel_weight == 0:
        return None
    pos = fd.omega[fd.omega > 0] / omega_scale
    below = [] if fd.freq_hz[0] == 0.0 else [pos[0] * x for x in _ANCHOR_BELOW]
    above = [x for x in _ANCHOR_ABOVE]
    s_v = 1j * np.array(below + above)
    lo, hi = h[int(np.argmax(fd.omega > 0))], h[-1]
    h_v = np.array([lo.real if x == 0 else lo for x in below] + [hi] * len(above))
    rel = _ANCHOR_WEIGHT if rel_weight is None else float(rel_weight)
    weight = rel * float(np.median(w[w > 0]))
    return np.asarray(s_v, dtype=complex), np.asarray(h_v, dtype=complex), weight


def _pole_bounds(fd: FrequencyData, omega_scale: float) -> tuple[float, float] | None:
    """Real-pole bounds of S fits (see :class:`_vf_core.Problem`); None for immittances
    and transfer functions, whose poles near 0 Hz are physical (a capacitor)."""
    if fd.kind != "S":
        return None
    lo = float(fd.omega[fd.omega > 0][0]) / omega_scale
    return lo / _POLE_SPAN[0], _POLE_SPAN[1]


def _max_order(n_freq: int, has_dc: bool, n_extra: int) -> int:
    # real equations per response: 2 per sample, 1 at 0 Hz; unknowns: N + n_extra (+1 for
    # the sigma constant). Keep at least one more equation than unknowns.
    n_eq = 2 * n_freq - int(has_dc)
    return max(n_eq - n_extra - 2, 0)


# ---------------------------------------------------------------------- main entry
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
        by a transmission's delay can be harder to fit than the plain data).

    out_of_band_weight : float, optional
        S data: weight, relative to the median data weight, of out-of-band anchor
        samples (below the band down to 0 Hz the lowest sample, above it the highest)
        that keep the model's out-of-band response of the size of the data; default
        1e-4 (barely felt in the band). Larger values (0.01-0.1) trade in-band accuracy
        for out-of-band passivity before an enforcement.

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
        pick = with_delay if e1 <= _DELAY_PAYS * floor else without
        for note in pick[1].notes:
            warnings.warn(note, FitWarning, stacklevel=2)
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
            # a response whose phase turns many times needs about two poles per turn:
            # no plateau is declared below that order
            min_order=min(cap, int(2 * _phase_turns(fd)) + 4),
        )
        coef, history, n_it, converged = auto.coef, auto.history, auto.n_iterations, auto.converged
        reason, noise = auto.reason, auto.noise_floor
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
        res = _vf_core.iterate(
            prob, reps, max_iterations=max_iterations, tol=tol, stable=enforce_stability
        )
        coef, history, n_it, converged = res.coef, res.history, res.n_iterations, res.converged
        reason, noise = f"order {n} given", None
    model = _to_model(coef, fd, omega_scale, fit_d=bool(fit_d), fit_e=bool(fit_e))
    if tau > 0:
        fd, model = data_fd, RationalModel(model.poles, model.residues, model.d, model.e,
                                           model.kind, model.z0, delay=tau)
    report = _make_report(
        model, fd, prob, coef, n_it, converged, reason, noise, history, wname
    )
    if order == "auto":
        report = _far_from_floor(report, fd, limit=cap)
    for note in report.notes:
        warnings.warn(note, FitWarning, stacklevel=2)
    if not converged:
        warnings.warn(
            f"vector fitting did not converge in {max_iterations} iterations per order "
            f"(relative RMS error {report.rel_rms_error:.3g}); raise max_iterations or "
            "change the order",
            FitWarning,
            stacklevel=2,
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


def _to_model(
    coef: _vf_core.Coefficients,
    fd: FrequencyData,
    omega_scale: float,
    *,
    fit_d: bool,
    fit_e: bool,
) -> RationalModel:
    reps = coef.reps
    nr = int(np.sum(reps.imag == 0))
    m = coef.c.shape[0]
    poles: list[complex] = []
    res: list[NDArray[np.complex128]] = []
    for j in range(nr):
        poles.append(complex(reps[j].real))
        res.append(coef.c[:, j].astype(complex))
    for j, p in enumerate(reps[nr:]):
        i = nr + 2 * j
        r = coef.c[:, i] + 1j * coef.c[:, i + 1]
        poles += [complex(p), complex(np.conj(p))]
        res += [r, np.conj(r)]
    # undo the frequency scaling: s' = s / w0, p = w0 p', r = w0 r', e = e' / w0
    p_arr = np.asarray(np.array(poles, dtype=complex) * omega_scale, dtype=complex)
    if poles:
        r_arr = np.asarray(
            np.array(res, dtype=complex).reshape(len(poles), fd.n_out, fd.n_in) * omega_scale,
            dtype=complex,
        )
    else:
        r_arr = np.zeros((0, fd.n_out, fd.n_in), complex)
    d = coef.d.reshape(fd.n_out, fd.n_in) if fit_d else np.zeros((fd.n_out, fd.n_in))
    e = coef.e.reshape(fd.n_out, fd.n_in) / omega_scale if fit_e else None
    if not (np.all(np.isfinite(p_arr)) and np.all(np.isfinite(r_arr)) and np.all(np.isfinite(d))):
        raise FitError("vector fitting produced non-finite poles or residues")
    del m
    return RationalModel(poles=p_arr, residues=r_arr, d=d, e=e, kind=fd.kind, z0=fd.z0)


def fit_errors(model: RationalModel, fd: FrequencyData) -> tuple[float, float, float]:
    """(rms_error, rel_rms_error, max_abs_error) of ``model`` against ``fd`` (CONTRACT 4)."""
    diff = model(fd.freq_hz) - fd.values
    rms = float(np.sqrt(np.mean(np.abs(diff) ** 2)))
    rel = float(np.linalg.norm(diff) / max(float(np.linalg.norm(fd.values)), 1e-300))
    return rms, rel, float(np.max(np.abs(diff)))


def point_errors(model: RationalModel, fd: FrequencyData) -> tuple[float, float]:
    """(RMS, max) over frequency of the per-point relative error
    ||H_model(f) - H_data(f)||_F / ||H_data(f)||_F (a zero sample counts against 1e-12
    of the largest)."""
    diff = np.linalg.norm((model(fd.freq_hz) - fd.values).reshape(fd.n_freq, -1), axis=1)
    norm = np.linalg.norm(fd.values.reshape(fd.n_freq, -1), axis=1)
    norm = np.maximum(norm, 1e-12 * float(np.max(norm)))
    e = diff / np.where(norm > 0, norm, 1.0)
    return float(np.sqrt(np.mean(e**2))), float(np.max(e))


def _constant_fit(fd: FrequencyData, wname: str) -> tuple[RationalModel, FitReport]:
    """Pole-free model of frequency-independent data: D = the (real) mean response."""
    d = fd.values.mean(axis=0).real
    model = RationalModel(
        poles=np.zeros(0, complex),
        residues=np.zeros((0, fd.n_out, fd.n_in), complex),
        d=d,
        kind=fd.kind,
        z0=fd.z0,
    )
    rms, rel, mx = fit_errors(model, fd)
    prms, pmax = point_errors(model, fd)
    reason = "constant data: no poles, D alone"
    return model, FitReport(
        order=0, n_iterations=0, rms_error=rms, rel_rms_error=rel,
        weighted_rel_rms_error=rel, max_abs_error=mx, converged=True,
        order_reason=reason, noise_floor=None, history=(), weighting=wname, kind=fd.kind,
        point_rel_rms_error=prms, point_rel_max_error=pmax,
    )


def _delay(fd: FrequencyData, delay: Any) -> float:
    """The common delay of ``vector_fit(delay=...)`` in seconds (0: none)."""
    if isinstance(delay, str):
        if delay not in ("auto", "none"):
            raise InputError("delay must be 'auto', 'none' or seconds", found=repr(delay))
        if delay == "none" or fd.kind in ("Z", "Y") or _phase_turns(fd) <= _DELAY_TURNS:
            return 0.0
        h = fd.values.reshape(fd.n_freq, -1)
        j = int(np.argmax(np.sum(np.abs(h) ** 2, axis=0)))
        ph = np.unwrap(np.angle(h[:, j]))
        # least-squares group delay of the largest entry (a transmission)
        return max(-float(np.polyfit(fd.omega, ph, 1)[0]), 0.0)
    tau = float(delay)
    if not (np.isfinite(tau) and tau >= 0):
        raise InputError("delay must be finite and >= 0 seconds", found=repr(delay))
    if tau > 0 and fd.kind in ("Z", "Y"):
        raise InputError(
            "a delay is supported for S and H data only",
            source=fd.source or _SRC,
            found=f"{fd.kind} data",
            expected="delay='none' or --kind S",
        )
    return tau


_DELAY_PAYS = 1.25  # delay="auto" keeps the delay when its error is within this factor
_DELAY_EXACT = 1e-6  # ... of the plain fit's error, its noise floor and this level
_FAR = 3.0  # an automatic fit this many times above the noise floor gets a note
_DELAY_TURNS = 5.0  # phase turns over the band that point at a delay


def _phase_turns(fd: FrequencyData) -> float:
    """Largest number of phase turns over the band among the entries carrying at least
    1 % of the energy: a long delay shows as many turns."""
    h = fd.values.reshape(fd.n_freq, -1)
    energy = np.sum(np.abs(h) ** 2, axis=0)
    turns = 0.0
    for j in np.flatnonzero(energy >= 1e-2 * energy.max()):
        ph = np.unwrap(np.angle(h[:, j]))
        turns = max(turns, float(abs(ph[-1] - ph[0]) / (2 * np.pi)))
    return turns


def _far_from_floor(report: FitReport, fd: FrequencyData, limit: int) -> FitReport:
    """Add a note when the automatic order stopped far above the noise floor, saying why."""
    floor = report.noise_floor or 0.0
    err = report.weighted_rel_rms_error
    if err <= _FAR * max(floor, 1e-9) or err < 1e-3:
        return report
    why = []
    turns = _phase_turns(fd)
    if turns > _DELAY_TURNS:
        why.append(
            f"the phase turns {turns:.0f} times over the band (a delay of about "
            f"{turns / max(fd.freq_hz[-1] - fd.freq_hz[0], 1e-300):.3g} s), which costs "
            "about two poles per turn"
        )
    if report.order >= limit - 1:
        why.append(f"the order limit {limit} was reached (raise max_order)")
    if not why:
        why.append("adding poles stopped improving the fit (noisy or non-rational data)")
    note = (
        f"the fit error {err:.3g} stays far above the estimated noise floor {floor:.3g} "
        f"at order {report.order}: " + "; ".join(why)
    )
    return replace(report, notes=(*report.notes, note))


def _make_report(
    model: RationalModel,
    fd: FrequencyData,
    prob: _vf_core.Problem,
    coef: _vf_core.Coefficients,
    n_it: int,
    converged: bool,
    reason: str,
    noise: float | None,
    history: tuple[_vf_core.IterationRecord, ...],
    wname: str,
) -> FitReport:
    rms, rel, mx = fit_errors(model, fd)
    prms, pmax = point_errors(model, fd)
    wrel = _vf_core.weighted_rel_rms(prob, _vf_core.evaluate(prob, coef))
    steps = tuple(
        FitStep(r.order, float(r.weighted_rel_rms), float(r.sigma_deviation)) for r in history
    )
    return FitReport(
        order=model.n_poles,
        n_iterations=int(n_it),
        rms_error=rms,
        rel_rms_error=rel,
        weighted_rel_rms_error=float(wrel),
        max_abs_error=mx,
        converged=bool(converged),
        order_reason=reason,
        noise_floor=None if noise is None else float(noise),
        history=steps,
        weighting=wname,
        kind=fd.kind,
        point_rel_rms_error=prms,
        point_rel_max_error=pmax,
    )
