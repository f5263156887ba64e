"""What :func:`vfmodel.fitting.vectfit.vector_fit` reports: :class:`FitReport`, the error
measures (:func:`fit_errors`, :func:`point_errors`), the model built from the fitted
coefficients and the pole-free model of constant data."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import FitError
from vfmodel.fitting import _vf_core
from vfmodel.fitting._fit_setup import _DELAY_TURNS, _phase_turns

_FAR = 3.0  # an automatic fit this many times above the noise floor gets a note


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


def _to_model(
    coef: _vf_core.Coefficients,
    fd: FrequencyData,
    omega_scale: float,
    *,
    fit_d: bool,
    fit_e: bool,
) -> RationalModel:
    reps = coef.reps
    nr = reps.size - int(np.count_nonzero(reps.imag))
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


def fit_errors(
    model: RationalModel, fd: FrequencyData, values: NDArray[np.complex128] | None = None
) -> tuple[float, float, float]:
    """(rms_error, rel_rms_error, max_abs_error) of ``model`` against ``fd`` (CONTRACT 4);
    ``values``: the model's response at ``fd.freq_hz`` if already evaluated."""
    diff = (model(fd.freq_hz) if values is None else values) - fd.values
    mag = np.abs(diff)
    rms = float(np.sqrt(np.mean(mag**2)))
    rel = _vf_core.frobenius(diff) / max(_vf_core.frobenius(fd.values), 1e-300)
    return rms, rel, float(mag.max())


def point_errors(
    model: RationalModel, fd: FrequencyData, values: NDArray[np.complex128] | None = None
) -> tuple[float, float]:
    """(RMS, max) over frequency of the per-point relative error
    ||H_model(f) - H_data(f)||_F / ||H_data(f)||_F (a zero sample counts against 1e-12
    of the largest); ``values`` as for :func:`fit_errors`."""
    hm = model(fd.freq_hz) if values is None else values
    diff = _vf_core.row_norms((hm - fd.values).reshape(fd.n_freq, -1))
    norm = _vf_core.row_norms(fd.values.reshape(fd.n_freq, -1))
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


def _far_from_floor(
    report: FitReport, fd: FrequencyData, limit: int, hit_max: bool = False,
    delay: float = 0.0,
) -> FitReport:
    """Add a note when the automatic order stopped far above the noise floor (or without
    one: ``noise_floor`` None), saying why. ``fd``: the data the rational part fitted,
    i.e. advanced by the common ``delay`` (s) when one was taken out: the sampling and the
    phase turns that explain the error are theirs (a PIN-diode waveguide cell, 137 turns,
    was fitted with its 13.6 ns delay taken out and still told the user that the phase
    turned 137 times, "which costs about two poles per turn")."""
    floor = report.noise_floor or 0.0
    err = report.weighted_rel_rms_error
    if err <= _FAR * max(floor, 1e-9) or err < 1e-3:
        return report
    why = []
    step, entry = _phase_step(fd)
    if step > _COARSE_STEP:
        why.append(
            f"the data are sampled too coarsely for the response: the phase of {entry} "
            f"advances by {step:.2g} rad per sample (median; about {2 * np.pi / step:.0f} "
            "samples per turn), so the response between samples is poorly determined (a long "
            "delay, e.g. the cables of a raw measurement: de-embed it, or measure with a "
            "finer frequency step)"
        )
    turns = _phase_turns(fd)
    taken = f" with the common delay of {delay:.3g} s taken out" if delay > 0 else ""
    if turns > _DELAY_TURNS:
        why.append(
            f"the phase turns {turns:.0f} times over the band{taken} (a delay of about "
            f"{turns / max(fd.freq_hz[-1] - fd.freq_hz[0], 1e-300):.3g} s), which costs "
            "about two poles per turn"
        )
    if hit_max or report.order >= limit - 1:
        why.append(f"the order limit {limit} was reached (raise max_order; at most "
                   f"{limit} poles for {fd.n_freq} samples)" if limit < 200 else
                   f"the order limit {limit} was reached (raise max_order)")
    if not why:
        why.append("adding poles stopped improving the fit (noisy or non-rational data"
                   + (f"; fitted{taken}, whatever of the response a single delay does "
                      "not explain, e.g. multiple reflections" if delay > 0 else "") + ")")
    if report.noise_floor is None:
        head = (f"the fit error {err:.3g} at order {report.order} is large and the data's "
                "noise floor could not be estimated (adjacent samples differ as much as "
                "the data)")
    else:
        head = (f"the fit error {err:.3g} stays far above the estimated noise floor "
                f"{floor:.3g} at order {report.order}")
    note = head + ": " + "; ".join(why)
    return replace(report, notes=(*report.notes, note))


# rad of phase per sample (median) from which the data are too coarse for a rational fit
# (about 6 samples per turn): scikit-rf's raw multiline-TRL and probe files turn 2.0-3.0
# rad per sample; SignalIntegrity's raw VNA files DUTRaw, Thru12, Open1 0.57-0.64 fit to
# 3.7e-3-0.33 at the order limit, vfbench's files at most 0.21
_COARSE_STEP = 1.0


def _phase_step(fd: FrequencyData) -> tuple[float, str]:
    """Largest median phase advance per sample (rad) among the entries carrying at least
    1 % of the energy, and that entry's name (e.g. "S21")."""
    h = fd.values.reshape(fd.n_freq, -1)
    energy = np.sum(np.abs(h) ** 2, axis=0)
    best, name = 0.0, ""
    for j in np.flatnonzero(energy >= 1e-2 * energy.max()):
        a, b = h[1:, j], h[:-1, j]
        ok = (a != 0) & (b != 0)
        if not np.any(ok):
            continue
        step = float(np.median(np.abs(np.angle(a[ok] / b[ok]))))
        if step > best:
            i, k = divmod(int(j), fd.n_in)
            best, name = step, f"{fd.kind}{i + 1}{k + 1}"
    return best, name


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
    hm = model(fd.freq_hz)
    rms, rel, mx = fit_errors(model, fd, hm)
    prms, pmax = point_errors(model, fd, hm)
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
