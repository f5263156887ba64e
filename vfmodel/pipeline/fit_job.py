"""The ``fit`` job: spectra -> vector fit -> passivity check/enforcement -> model (+ SPICE).

Several spectra are fitted together with common poles as a block-diagonal model: file k
contributes its ports to the block k (all files must share the frequency grid and, after
conversion, the kind).

By default samples that are not data are left out of the fit (with a
:class:`~vfmodel.errors.FitWarning`): a trailing run repeating the last computed sample
bit for bit (export padding) is dropped, and isolated single-sample spikes get zero weight
(see :mod:`vfmodel.fitting.artifacts`). Errors are reported over the remaining samples,
spikes included.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from typing import Any, Literal

import numpy as np

from vfmodel._choices import DcMode, Kind, Weighting
from vfmodel.core.blas import capped_blas
from vfmodel.core.frequency_data import FrequencyData, as_frequency_data
from vfmodel.core.progress import Progress, no_progress
from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import FitWarning, InputError, PassivityError, SolverError
from vfmodel.fitting.artifacts import DataArtifacts, find_artifacts
from vfmodel.fitting.data_passivity import DataPassivity, data_passivity
from vfmodel.fitting.defaults import ENFORCE_ITERATIONS, ENFORCE_TIME_LIMIT
from vfmodel.fitting.foster import backward_reflections
from vfmodel.fitting.out_of_band_poles import with_out_of_band_poles
from vfmodel.fitting.passive_polish import centred_on_data
from vfmodel.fitting.passive_relocation import relocate_passive
from vfmodel.fitting.passivity import PassivityReport, check_passivity, enforce_passivity
from vfmodel.fitting.vectfit import FitReport, data_noise, fit_errors, point_errors, vector_fit


@dataclass(frozen=True)
class FitJobResult:
    """What the ``fit`` job produced (``data``: the samples fitted, padding dropped)."""

    data: FrequencyData
    model: RationalModel
    fit: FitReport
    passivity: PassivityReport | None
    unconstrained_rel_rms_error: float
    rms_error: float
    rel_rms_error: float
    artifacts: DataArtifacts | None = None
    data_passivity: DataPassivity | None = None


def combine_spectra(spectra: Any, kind: Kind | None) -> FrequencyData:
    """One block-diagonal response from several spectra on the same frequency grid
    (``spectra``: one data argument -- FrequencyData, skrf.Network or path -- or a list
    of them)."""
    items = list(spectra) if isinstance(spectra, list | tuple) else [spectra]
    if not items:
        raise InputError("no spectrum given", expected="one or more spectrum files")
    fds: list[FrequencyData] = [as_frequency_data(s, source="run_fit") for s in items]
    target: Kind = kind or fds[0].kind
    conv = [s.to_kind(target) if target != "H" or s.kind == "H" else s for s in fds]
    if target == "H" and any(s.kind != "H" for s in fds):
        raise InputError("cannot fit network parameters as H", expected="--kind Z, Y or S")
    if len(conv) == 1:
        return conv[0]
    f0 = conv[0].freq_hz
    for s in conv[1:]:
        if s.n_freq != f0.size or np.max(np.abs(s.freq_hz - f0)) > 1e-9 * f0[-1]:
            raise InputError(
                "spectra fitted together must share the frequency grid",
                source=s.source,
                found=f"{s.n_freq} points {s.freq_hz[0]:g}-{s.freq_hz[-1]:g} Hz",
                expected=f"the {f0.size} points of {conv[0].source}",
            )
    z0s = {s.z0 for s in conv}
    if target == "S" and len(z0s) > 1:
        raise InputError("S spectra with different z0", found=str(sorted(z0s)))  # type: ignore[type-var]
    n_out = sum(s.n_out for s in conv)
    n_in = sum(s.n_in for s in conv)
    values = np.zeros((f0.size, n_out, n_in), complex)
    i = j = 0
    labels: list[str] = []
    for s in conv:
        values[:, i : i + s.n_out, j : j + s.n_in] = s.values
        i, j = i + s.n_out, j + s.n_in
        stem = (s.source or "spectrum").rsplit("/", 1)[-1]
        labels += [f"{stem}:{k + 1}" for k in range(s.n_out)]
    return FrequencyData(f0, values, kind=target, z0=conv[0].z0, labels=tuple(labels),
                         source=", ".join(s.source or "?" for s in conv))


@capped_blas
def run_fit(
    spectra: Any,
    *,
    order: int | Literal["auto"] = "auto",
    kind: Kind | None = None,
    weighting: Weighting = "auto",
    passive: bool = False,
    clean: bool = True,
    progress: Progress = no_progress,
    max_order: int | None = None,
    target_error: float | None = None,
    delay: float | Literal["auto", "none"] = "none",
    dc: DcMode = "enforce",
    enforce_iterations: int = ENFORCE_ITERATIONS,
    enforce_margin: float | None = None,
    enforce_time_limit: float | None = ENFORCE_TIME_LIMIT,
) -> FitJobResult:
    """Fit, then check (and with ``passive`` enforce) passivity of Z, Y and S models.

    ``spectra``: one data argument (:class:`FrequencyData`, ``skrf.Network`` or a path to
    a Touchstone/CSV file) or a list of them, fitted together (:func:`combine_spectra`).

    ``clean``: leave export padding and isolated spikes out of the fit (module docstring).
    The data's own passivity violation floor is measured first; with ``passive``, active
    data (floor above 5 %) are refused, and an enforcement that finds no certificate is
    reported as an :class:`InputError` naming the options that control it.
    ``enforce_margin`` None: 1e-6, or a tenth of max(fit error, data floor) when that is
    smaller, at least 1e-10 (:func:`enforce_margin_for`). ``enforce_time_limit``: seconds
    from the start of passivity enforcement after which the running convex program stops
    and no further one starts (the first enforcement and, for S models of at most 4 ports,
    its retries; None or 0: no limit); a model kept because of it carries a note saying so,
    and no certified model by then is an :class:`InputError` naming the option.
    """
    if enforce_time_limit is not None and not enforce_time_limit >= 0:  # NaN too
        raise InputError("enforce_time_limit must be a number of seconds >= 0 (0: no limit)",
                         found=repr(enforce_time_limit), expected="seconds >= 0, or None")
    data = combine_spectra(spectra, kind)
    art: DataArtifacts | None = None
    spikes: tuple[int, ...] = ()
    if clean:
        art = find_artifacts(data)
        if art.found:
            warnings.warn(
                f"{data.source or 'spectrum'}: {art.describe()}; left out of the fit",
                FitWarning,
                stacklevel=3,
            )
            k = art.n_genuine
            data = FrequencyData(data.freq_hz[:k], data.values[:k], kind=data.kind,
                                 z0=data.z0, labels=data.labels, source=data.source)
            spikes = art.spikes
    dp = data_passivity(data)
    if passive and dp is not None and dp.active:
        raise InputError(
            "the data are active (gain): a passive model cannot come closer to them than "
            f"{100 * dp.floor:.3g} % (largest violation {dp.worst_violation:.3g} at "
            f"{dp.worst_freq_hz:.6g} Hz); passivity enforcement refused",
            source=data.source,
            expected="passive data for --passive (fit without --passive to model an "
            "active device)",
        )
    progress("vector fit", 0, 2 if passive else 1)
    fit_kw: dict[str, Any] = {"order": order, "weighting": weighting, "exclude": spikes or None,
              "max_order": max_order, "target_error": target_error, "dc": dc,
              "delay": delay}
    model, report = vector_fit(data, **fit_kw)
    _, unconstrained_rel, _ = fit_errors(model, data)
    progress("vector fit", 1, 2 if passive else 1)
    pas: PassivityReport | None = None
    bound: float | None = None  # what an enforcement is held to, when one ran
    if data.kind in ("Z", "Y", "S") and data.n_out == data.n_in:
        pas = check_passivity(model)
        if passive and not pas.passive:
            first: tuple[RationalModel, PassivityReport, FitReport] | None = None
            failure = ""
            # S models get a second chance with out-of-band anchors (below): the first
            # enforcement then stops early
            retry = data.kind == "S" and data.n_in <= _RETRY_PORTS
            first_iter = min(enforce_iterations, _FIRST_ITERATIONS) if retry \
                else enforce_iterations
            floor = dp.floor if dp else 0.0
            margin = enforce_margin if enforce_margin is not None else \
                enforce_margin_for(unconstrained_rel, floor)
            # the change is minimised in the norm the fit minimised: uniform for S data
            # (the relative RMS error over all entries), per entry relative otherwise.
            # Measured, enforcement alone, uniform against relative (vfbench files):
            # hfss_18.2 1.02x against 1.26x its bound, mlin 2.9x against 5.9x
            # the default margin only helps the programs (it may be given back); a margin
            # the user asked for is kept at the cut frequencies
            enforce_weighting: Literal["uniform", "relative"] = \
                "uniform" if report.weighting == "uniform" else "relative"
            bound_args = partial(enforce_passivity, data=data, margin=margin,
                                 allow_active=True, keep_margin=enforce_margin is not None,
                                 weighting=enforce_weighting, progress=progress)
            # the time limit covers every enforcement: the first one and, for S models of
            # at most _RETRY_PORTS ports, its retries. A 4-port coupler's first
            # enforcement (64 poles, 2,400-2,900 cuts) ran for more than 14 minutes, its
            # programs growing to 3.5-6 minutes each (measured with another job on the
            # second core); an 8-port model of four coupled lines (42 poles, 700 points,
            # no retries: session 43's unseen set) was at its 16th of 30 programs after
            # 16 minutes, at 1.9-2.05 GB (two runs), before the limit covered models
            # without retries
            clock = _EnforceClock(enforce_time_limit, hold=_POLISH_SHARE if retry else 0.0)

            def enforce(m: RationalModel, *, max_iter: int
                        ) -> tuple[RationalModel, PassivityReport]:
                return bound_args(m, max_iter=max_iter, time_limit=clock.remaining())
            try:
                enforced, pas_e = enforce(model, max_iter=first_iter)
                first = (enforced, pas_e, report)
            except (PassivityError, SolverError) as err:  # the retries may still succeed
                failure = str(err)
            # the retries below aim at this bound; not below two margins (an enforced
            # change is at least of the order of the margin: a fit exact to 1e-15 cannot
            # be enforced within 1.2x of it, and retrying cost 11 s on a 2-pole capacitor)
            bound = max(_ENFORCE_RATIO * max(unconstrained_rel, floor), 2 * margin)

            def wanted(first: tuple[RationalModel, PassivityReport, FitReport] | None
                       ) -> bool:
                return (first is None or fit_errors(first[0], data)[1] > bound) \
                    and not clock.out()
            if retry and wanted(first):
                first = _extra_poles_retry(model, data, first, report, enforce, first_iter)
            if retry and wanted(first):
                first = _out_of_band_retry(data, first, fit_kw, enforce,
                                           enforce_iterations, bound, clock)
            unknowns = data.n_in**2 * model.n_poles
            fixed = data.n_in <= _RELOCATE_PORTS and unknowns <= _RELOCATE_UNKNOWNS
            if retry and (fixed or unknowns <= _CONTINUATION_UNKNOWNS) and wanted(first):
                first = _relocation_retry(model, data, first, report, enforce,
                                          first_iter, bound, clock, fixed=fixed)
            clock.release()
            if retry and first is not None and wanted(first):
                first = _polish_retry(data, first, enforce, first_iter, enforce_weighting,
                                      bound)
            if first is not None and clock.stopped:
                note = clock.note(fit_errors(first[0], data)[1], bound)
                warnings.warn(note, FitWarning, stacklevel=3)
                first = (first[0], first[1], replace(first[2], notes=(*first[2].notes, note)))
            if first is None and (clock.stopped or clock.out()):
                raise InputError(
                    f"no certified passive model within the time limit of {clock.limit:g} "
                    f"s: {failure}{_violation_place(pas, data)}",
                    source=data.source,
                    expected="more time (--enforce-time-limit, 0: no limit), or a model "
                    "that is cheaper to make passive: lower the order (--max-order)",
                )
            if first is None:
                raise InputError(
                    f"passivity enforcement found no certificate: {failure}"
                    f"{_violation_place(pas, data)}",
                    source=data.source,
                    expected="a model that can be made passive: raise "
                    "--enforce-iterations, change --enforce-margin or lower the order",
                )
            model, pas, report = first
    elif passive:
        raise InputError(
            "passivity is defined for square Z, Y or S data only",
            found=f"{data.kind} {data.n_out}x{data.n_in}",
            expected="--kind Z, Y or S",
        )
    if passive:
        progress("vector fit", 2, 2)
    rms, rel, _ = fit_errors(model, data)
    report = replace(report, rms_error=rms, rel_rms_error=rel)  # errors of the final model
    if bound is not None:
        report = _beyond_bound(report, data, unconstrained_rel, dp.floor if dp else 0.0,
                               bound)
    prms, pmax = point_errors(model, data)
    report = replace(report, point_rel_rms_error=prms, point_rel_max_error=pmax)
    return FitJobResult(data, model, report, pas, unconstrained_rel, rms, rel, art, dp)


class _EnforceClock:
    """The time limit of passivity enforcement (``run_fit(enforce_time_limit=)``),
    started before the first enforcement; :meth:`out` is True once it has passed. It is
    asked where a further enforcement would start and by the enforcements themselves
    before each convex program (:meth:`remaining`), so a True answer is a cut
    (``stopped``, which the fit note reports). ``hold``: the share of the limit kept back
    from the retries (their deadline is that much earlier) until :meth:`release`, for the
    last step (the polish, ``_polish_retry``)."""

    def __init__(self, limit: float | None, hold: float = 0.0) -> None:
        self.limit = float(limit) if limit else None
        self.deadline = None if self.limit is None else time.monotonic() + self.limit
        self.held = 0.0 if self.limit is None else hold * self.limit
        self.stopped = False

    def release(self) -> None:
        """Give back the share held back (for the last step: the polish)."""
        self.held = 0.0

    def out(self) -> bool:
        if self.deadline is not None and time.monotonic() > self.deadline - self.held:
            self.stopped = True
            return True
        return False

    def remaining(self) -> float | None:
        """Seconds left (0 once passed), None without a limit."""
        if self.deadline is None:
            return None
        return max(self.deadline - self.held - time.monotonic(), 0.0)

    def note(self, err: float, bound: float) -> str:
        return (f"passivity enforcement stopped at the time limit ({self.limit:g} s; "
                f"--enforce-time-limit): enforced error "
                f"{err:.3g}" + (f" against the bound {bound:.3g}" if err > bound else ""))


Enforce = Callable[..., tuple[RationalModel, PassivityReport]]
"""``enforce_passivity`` with the fit job's data, margin and weighting bound
(``enforce(model, max_iter=...)``)."""

_ENFORCE_RATIO = 1.2  # enforced error within this factor of max(fit error, data floor)
_MARGIN = (1e-6, 0.1, 1e-10)  # default margin, its share of the error bound, its floor
_FIRST_ITERATIONS = 15  # S: programs of the first enforcement (anchored refits follow)
_RETRY_PORTS = 4  # anchored refits for S models of at most this many ports (cost)
# the extra out-of-band poles and the relocation's second start were for S models of at
# most 2 ports until session 37 (a 3-port HFSS export once ran for more than 7 minutes,
# loaded); now for all the anchored retries take (_RETRY_PORTS). Measured in session 37 on
# the 3-4 port files of vfbench and the unseen sets (enforced error / max(fit error, data
# floor), run_fit time): front_face 62x -> 25x, Ideal_TRL 8.1x -> 2.4x, M_Strip 5.7x ->
# 3.5x (3.7 -> 32 s), hfss_18.2 1.29x (216 s) -> 1.10x (20 s) with one OpenBLAS kernel
# (2.63x either way with Haswell); the other 11 unchanged or within 1.2x either way, at a cost of
# up to 55 s where nothing was gained (ku-cms T1, 4 ports, 155 poles: 24 -> 79 s, loaded);
# a lossless 4-port coupler (tests/test_passive_relocation.py) 5.2x -> 2.1x
_OOB_WEIGHTS = (1e-2, 1e-1)  # stronger out-of-band anchors tried when enforcement costs more
# relocation against the enforced model out of band (fitting.passive_relocation): S models
# of at most this many ports (each round is one enforcement), rounds at most
_RELOCATE_PORTS = 3
# ... and of at most this many residue unknowns (ports^2 x poles): a 3-port HFSS model of
# 61 poles took ~8 s per program, i.e. minutes per round
_RELOCATE_UNKNOWNS = 300
_RELOCATE_ROUNDS = 16
# the continuation's start alone (passive_relocation, session 40) for the retried S models
# beyond those limits (4 ports, or 300-800 residue unknowns). Measured, one BLAS thread,
# enforced error / max(fit error, data floor), before -> after (run_fit time): M_Strip
# 3.46x -> 1.31x (301 s), milanofthe 4port 1.69x -> 1.33x (70 s), front_face 25.5x ->
# 2.58x (301 s), Ideal_TRL 2.38x -> 1.13x (302 s, at the limit: 1.72x under more load);
# 2 ports: S1 (106 poles) 36x (26 s) -> 17.8x (304 s), Spiral_Inductor's CLI fit (78
# poles) 5.27x (46 s) -> 4.26x (303 s). The fixed-weight starts for 4 ports ran to the
# time limit for less (session 37); the continuation spends it on files beyond 1.2x
_CONTINUATION_UNKNOWNS = 800
_RELOCATE_WEIGHT = 0.1  # weight of the passive out-of-band targets relative to the data
# share of the time limit held back from the retries for the polish (_polish_retry, session
# 41). Measured, one BLAS thread, enforced error / max(fit error, data floor), before ->
# after: Clarity_example 1.66x -> 1.07x, wr2p2,line 1.99x -> 1.07x, M_Strip 1.31x -> 1.03x
# (the polish in the last 45 s), milanofthe 4port 1.33x -> 1.29x, COMSOL 5.97x -> 4.95x;
# Ideal_TRL 1.13x -> 1.72x (its continuation reached 1.13x only in the last 45 s of 300;
# with 10 % held back: 1.72x, and M_Strip's polish no longer ends in time: 1.31x)
_POLISH_SHARE = 0.15


def _violation_place(pas: PassivityReport, data: FrequencyData) -> str:
    """Where the fitted model violates passivity before enforcement, relative to the
    data's band, for the message of a failed enforcement: a violation above or below the
    band is the model's own out-of-band behaviour (an 8-port ADS model of coupled lines
    fitted to 70 GHz: sigma_max 8-21 from 80 to 140 GHz, D of 40.8, and no certificate
    within 300 s), which a lower order reduces (24 poles: certified in 16 s)."""
    f = pas.worst_freq_hz
    if pas.passive or pas.worst_violation <= 0 or f is None:
        return ""
    lo, hi = float(data.freq_hz[0]), float(data.freq_hz[-1])
    place = "above" if f > hi else "below" if f < lo else "inside"
    return (f"; before enforcement the fitted model is {pas.describe()}, its worst "
            f"violation {place} the data's band ({lo:.4g}-{hi:.4g} Hz)")


def enforce_margin_for(fit_error: float, floor: float) -> float:
    """Default passivity margin of ``fit --passive``: 1e-6, or a tenth of the error the
    enforced model is held to (max of fit error and data floor) when that is smaller, at
    least 1e-10. A fixed 1e-6 pulled every singular value of a lossless model (fit to
    5e-10) 1e-6 inside the unit circle, i.e. a change 2000x its error (ntwk1.s2p, open.s2p);
    the floor keeps 100x above the certificate's tolerance (1e-12 of the response)."""
    base, share, least = _MARGIN
    return float(min(base, max(share * max(fit_error, floor), least)))


def _beyond_bound(report: FitReport, data: FrequencyData, fit_rel: float, floor: float,
                  bound: float) -> FitReport:
    """A note (and a :class:`FitWarning`) when the enforced model ends beyond ``bound``
    (run_fit's: 1.2x max(fit error, data floor), at least two margins): how far, and
    whether the data hold a near-lossless reflection that turns the wrong way
    (:mod:`vfmodel.fitting.foster`)."""
    if report.rel_rms_error <= bound:
        return report
    ratio = report.rel_rms_error / max(fit_rel, floor, 1e-300)
    note = (f"passivity enforcement left the model {ratio:.3g}x max(fit error "
            f"{fit_rel:.3g}, data floor {floor:.3g}) from the data (beyond "
            f"{_ENFORCE_RATIO}x)")
    bad = backward_reflections(data)
    if bad:
        ports = ", ".join(f"{i + 1} ({100 * share:.0f} % of the band)" for i, share in bad)
        note += (f": the reflection of port {ports} has a magnitude near 1 and turns "
                 "counter-clockwise with frequency, which no causal passive port does "
                 "(Foster's reactance theorem; a reference plane beyond the device?), so "
                 "no passive model follows these data")
    warnings.warn(note, FitWarning, stacklevel=3)
    return replace(report, notes=(*report.notes, note))


def _extra_poles_retry(
    model: RationalModel,
    data: FrequencyData,
    first: tuple[RationalModel, PassivityReport, FitReport] | None,
    report: FitReport,
    enforce: Enforce,
    max_iter: int,
) -> tuple[RationalModel, PassivityReport, FitReport] | None:
    """Enforce again with real poles added out of band (zero residues,
    :func:`vfmodel.fitting.out_of_band_poles.with_out_of_band_poles`); keep the passive model
    closest to the data. Not when the data has fewer real equations per response than
    the augmented model has unknowns plus two (as the fit's order limit): poles the
    samples cannot see left the programs of a 3-point file ill-conditioned (30 programs,
    290 s, no certificate)."""
    extended = with_out_of_band_poles(model, data.freq_hz)
    if extended.n_poles + 3 > 2 * data.n_freq:
        return first
    try:
        enforced, check = enforce(extended, max_iter=max_iter)
    except (PassivityError, SolverError):
        return first
    if not check.passive or (first is not None and fit_errors(enforced, data)[1]
                             >= fit_errors(first[0], data)[1]):
        return first
    return enforced, check, replace(report, order=enforced.n_poles)


def _relocation_retry(
    model: RationalModel,
    data: FrequencyData,
    first: tuple[RationalModel, PassivityReport, FitReport] | None,
    report: FitReport,
    enforce: Enforce,
    max_iter: int,
    bound: float,
    clock: _EnforceClock,
    *,
    fixed: bool = True,
) -> tuple[RationalModel, PassivityReport, FitReport] | None:
    """Relocate the poles against the enforced model out of band and enforce again
    (:func:`vfmodel.fitting.passive_relocation.relocate_passive`); keep the passive model
    closest to the data. ``fixed``: the two starts at the fixed target weight first, then
    the continuation from the best passive model; otherwise the continuation alone."""

    def passive(m: RationalModel) -> RationalModel | None:
        if check_passivity(m).passive:
            return m
        try:
            return enforce(m, max_iter=max_iter)[0]
        except (PassivityError, SolverError):  # one round's program failed: not kept
            return None

    best = first
    best_err = np.inf if first is None else fit_errors(first[0], data)[1]
    # first targets: the best passive model so far (no enforcement of the fit, which can
    # fail or take minutes), then the enforced fit itself (measured: Clarity_example 1.06x
    # vs 1.47x, cpw 4.4x vs 2.6x); then the continuation from the best of these
    starts: list[RationalModel | None] = \
        (([] if first is None else [first[0]]) + [None]) if fixed else []
    for k in range(len(starts) + 1):
        if clock.out():
            break
        continuation = k == len(starts)
        start = (None if best is None else best[0]) if continuation else starts[k]
        found = relocate_passive(model, data, passive, rounds=_RELOCATE_ROUNDS,
                                 out_weight=_RELOCATE_WEIGHT, good_enough=bound,
                                 initial=start, stop=clock.out, continuation=continuation)
        if found is not None and found[1] < best_err:
            check = check_passivity(found[0])
            if check.passive:
                reason = (f"{report.order_reason}; for passivity the poles were relocated "
                          f"against the enforced model out of band ({found[0].n_poles} poles)")
                best = (found[0], check, replace(report, order=found[0].n_poles,
                                                 order_reason=reason))
                best_err = found[1]
        if best_err <= bound:
            break
    return best


def _polish_retry(
    data: FrequencyData,
    first: tuple[RationalModel, PassivityReport, FitReport],
    enforce: Enforce,
    max_iter: int,
    weighting: str,
    bound: float,
) -> tuple[RationalModel, PassivityReport, FitReport]:
    """The passive model nearest the data at the poles of the best one, then at those
    poles with real poles added out of band (:mod:`vfmodel.fitting.passive_polish`);
    each step is at most as far from the data as the model it starts from."""
    best, best_err = first, fit_errors(first[0], data)[1]
    for extend in (False, True):
        if best_err <= bound:
            break
        model = best[0]
        if extend:  # the real poles out of band it does not have yet
            model = with_out_of_band_poles(model, data.freq_hz)
            if model.n_poles == best[0].n_poles:
                continue
        try:
            enforced, check = enforce(centred_on_data(model, data, weighting=weighting),
                                      max_iter=max_iter)
        except (PassivityError, SolverError):
            continue
        err = fit_errors(enforced, data)[1]
        if check.passive and err < best_err:
            added = ", real poles added out of band" if extend else ""
            reason = (f"{first[2].order_reason}; the residues were refitted to the data "
                      f"under the passivity constraint ({enforced.n_poles} poles{added})")
            best = (enforced, check, replace(first[2], order=enforced.n_poles,
                                             order_reason=reason))
            best_err = err
    return best


def _out_of_band_retry(
    data: FrequencyData,
    first: tuple[RationalModel, PassivityReport, FitReport] | None,
    fit_kw: dict[str, Any],
    enforce: Enforce,
    max_iter: int,
    bound: float,
    clock: _EnforceClock,
) -> tuple[RationalModel, PassivityReport, FitReport] | None:
    """Refit an S model with stronger out-of-band anchors and enforce again; keep the
    passive model closest to the data. Out-of-band excursions of a narrow-band fit (|S| of
    1.35 at 0 Hz for a 500-750 GHz reflection) make enforcement distort the band; a fit
    that stays bounded out of band needs only a small change."""
    best = first
    best_err = np.inf if first is None else fit_errors(first[0], data)[1]
    for wgt in _OOB_WEIGHTS:
        if clock.out():
            break
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FitWarning)
            model, report = vector_fit(data, out_of_band_weight=wgt, **fit_kw)
        check = check_passivity(model)
        if not check.passive:
            try:
                model, check = enforce(model, max_iter=max_iter)
            except (PassivityError, SolverError):
                continue
        err = fit_errors(model, data)[1]
        if check.passive and err < best_err:
            best, best_err = (model, check, report), err
        if best_err <= bound:
            break
    return best


def spectrum_summary(data: FrequencyData) -> dict[str, Any]:
    """What ``vfmodel info FILE`` says about one spectrum: kind, ports, reference
    impedance, points, frequency range and spacing, size range of ||H(f)||_F, the noise
    estimate (relative, as the automatic order sees it), export artifacts and, for square
    Z/Y/S data, the passivity violation floor (active or not)."""
    f = data.freq_hz
    pos = f[f > 0]
    norm = np.linalg.norm(data.values.reshape(data.n_freq, -1), axis=1)
    spacing = "single point"
    if pos.size >= 3:
        lin = np.ptp(np.diff(pos)) <= 1e-6 * pos[-1]
        spacing = "linear" if lin else ("logarithmic" if np.ptp(np.diff(np.log(pos)))
                                         <= 1e-6 else "irregular")
    noise = data_noise(data)
    art = find_artifacts(data) if data.n_freq >= 3 else None
    dp = data_passivity(data)
    return {
        "source": data.source,
        "kind": data.kind,
        "ports": [data.n_out, data.n_in],
        "z0_ohm": data.z0,
        "n_points": data.n_freq,
        "f_min_hz": float(f[0]),
        "f_max_hz": float(f[-1]),
        "spacing": spacing,
        "norm_min": float(np.min(norm)),
        "norm_max": float(np.max(norm)),
        "noise_rel": noise,
        "artifacts": None if art is None or not art.found else art.describe(),
        "passivity_floor": None if dp is None else dp.floor,
        "worst_violation": None if dp is None else dp.worst_violation,
        "active": None if dp is None else dp.active,
    }


def fit_model_json(res: FitJobResult, sources: list[str]) -> dict[str, Any]:
    """The ``model.json`` document of ``vfmodel fit`` (CONTRACT section 4): the model, its
    fit errors and passivity status, the passivity details when checked, the order reason
    and the source files."""
    from vfmodel.fitting.model_json import model_to_json, passivity_to_json

    f = res.data.freq_hz
    obj = model_to_json(res.model, res.fit, (float(f[0]), float(f[-1])),
                        None if res.passivity is None else res.passivity.passive)
    if res.passivity is not None:
        obj["passivity"] = passivity_to_json(res.passivity, res.unconstrained_rel_rms_error,
                                             res.data_passivity)
    obj["order_reason"] = res.fit.order_reason
    obj["sources"] = list(sources)
    return obj


def fit_spice_text(res: FitJobResult, subckt_name: str) -> str:
    """SPICE subcircuit ``subckt_name`` of the fitted model (``fit --spice``); a model with
    a common delay is the rational part behind matched lossless lines."""
    from vfmodel.circuit.spice_export import delayed_subckt
    from vfmodel.circuit.synthesis import model_to_spice

    if res.model.delay:
        inner = f"{subckt_name}_rational"
        return delayed_subckt(model_to_spice(res.model.without_delay(), name=inner),
                              inner, subckt_name, res.model.n_in,
                              float(res.model.z0 or 50.0), res.model.delay)
    return model_to_spice(res.model, name=subckt_name)
