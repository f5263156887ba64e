"""The ``reproduce`` job: the reference paper's pipeline on a dataset (CONTRACT sections 3, 6).

identify the grey-box network (:func:`vfmodel.greybox.identify.identify`) -> validate it
(impedance MAPE and coherence coefficient, bearing-voltage peak errors and spectral
correlation per speed, :mod:`vfmodel.greybox.metrics`) -> the classical BVR model
(:mod:`vfmodel.greybox.bearing`) -> black box vs grey box
(:mod:`vfmodel.greybox.blackbox`) -> the identified network of each speed as an ngspice
netlist. Returns values; writing files is the caller's (CLI) job.

``results.json`` holds the keys of CONTRACT section 6 (definitions in
:mod:`vfmodel.greybox.metrics`) and more: ``bearing.<rpm>.lubricant`` is the equivalent
film of one bearing (:func:`vfmodel.greybox.bearing.film_equivalent`: ``r_ohm`` its DC
resistance, ``c_f`` its capacitance); at standstill the metallic contact shorts the film and
both are reported as 0. ``residual_rms_v`` is the RMS of measured minus modelled bearing
voltage (filtered): at standstill it is mostly measurement noise, and the measured peak
(the maximum of signal plus noise over many switching events) then exceeds the noise-free
peak by a few times this value. ``model`` holds the identified parameters, their relative standard
uncertainties and the stages; ``model.divider_intervals`` and
``bearing.<rpm>.lubricant_interval`` are 95 % intervals in which, with the metallic contact,
the rotor current's path inductances and the parameters the contact hides are known only
through their physics priors (:mod:`vfmodel.greybox.path_prior`: the standstill data fix
``C_wr`` times the path impedance, not the scale; ``C_wr`` and the bearing capacitance are
identifiable only through those priors; ``lubricant_interval.cm_transfer_100khz`` is the
bearing voltage per volt of common-mode terminal voltage at 100 kHz, the plateau level that
the record fixes whatever that scale). The lubricant intervals also hold the network's
structural error of that plateau level, measured on the record
(``lubricant_interval.model_error``, :mod:`vfmodel.greybox.model_error`; how each interval
is formed: ``model.interval_method``); ``blackbox`` the band errors of grey and black box;
``greybox_beats_baseline`` the per-speed comparison of relative peak errors.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vfmodel._choices import SectionsBy, check_choice
from vfmodel.circuit.spice_export import to_spice
from vfmodel.core.blas import capped_blas
from vfmodel.core.dataset import Dataset
from vfmodel.core.progress import Progress, no_progress
from vfmodel.errors import InputError
from vfmodel.greybox.bearing import (
    BvrBaseline,
    bearing_capacitance,
    bvr_baseline,
    divider_capacitances,
    film_equivalent,
    film_time_constant,
    predict_bvr,
)
from vfmodel.greybox.bearing import bvr as bvr_estimate
from vfmodel.greybox.blackbox import BlackBoxComparison, compare_blackbox
from vfmodel.greybox.effects import (
    JOINT_REFIT,
    LUBRICANT_MAX_NFEV,
    LUBRICANT_RANDOM_STARTS,
    PAPER_EFFECTS,
    SECTIONS,
)
from vfmodel.greybox.identify import (
    STANDSTILL_HIDDEN,
    Identification,
    RotatingFit,
    StandstillFit,
    identify,
)
from vfmodel.greybox.joint import SHARED
from vfmodel.greybox.lsq import LogCovariance, log_interval, lower_bound_only, widen_interval
from vfmodel.greybox.metrics import (
    coherence_coefficient,
    mape_pct,
    peak_errors,
    peak_v,
    plateau_rel_err_pct,
    settled_window,
    spectral_corr,
    spectral_corr_periodogram,
)
from vfmodel.greybox.model_error import plateau_discrepancy
from vfmodel.greybox.params import ParamSet
from vfmodel.greybox.path_prior import with_path_prior
from vfmodel.greybox.priors import parameter_priors
from vfmodel.greybox.propagate import with_machine_uncertainty
from vfmodel.greybox.section_choice import identify_by_records

__all__ = ["ReproduceResult", "SpeedResult", "netlist_text", "reproduce", "rpm_key"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]


INTERVAL_METHOD = {
    "divider_intervals": "delta method on the last machine stage's covariance of log p "
                         "(chi2_red and residual-correlation scaled, path prior); no "
                         "model-error term: the standstill record has no plateau level to "
                         "check the network against",
    "lubricant_interval": "delta method on the speed's stage covariance (chi2_red and "
                          "residual-correlation scaled) with the machine's, plus the "
                          "structural model error: std_log^2 = std_log_noise^2 + "
                          "model_error_log^2, model_error_log = |beta| tau, tau from "
                          "lubricant_interval.model_error (vfmodel.greybox.model_error), "
                          "beta the regression of log q on log cm_transfer_100khz in the "
                          "speed's own stage covariance; r_ohm is a lower bound only "
                          "(bound 'lower', hi null) when 2 pi times the 95 % upper end of "
                          "the film's slowest time constant (time_constant_s) exceeds the "
                          "record's duration (record_s)",
}
"""How results.json's 95 % intervals are formed (``model.interval_method``)."""


def rpm_key(speed_rpm: float) -> str:
    """Speed as a results.json key: ``'100'`` (integer speeds), else ``'%g'``."""
    return str(round(speed_rpm)) if abs(speed_rpm - round(speed_rpm)) < 1e-9 else f"{speed_rpm:g}"


@dataclass(frozen=True)
class SpeedResult:
    """Validation of one recording: filtered measurement, model and divider outputs."""

    speed_rpm: float
    fs: float
    u_meas: ArrF
    u_model: ArrF
    u_bvr: ArrF
    terminals: ArrF
    baseline: BvrBaseline
    bvr_freq_hz: ArrF
    bvr_meas: ArrC
    bvr_model: ArrC
    h1_freq_hz: ArrF
    h1_meas: ArrC
    h1_model: ArrC


@dataclass(frozen=True)
class ReproduceResult:
    """``results`` is the JSON document (CONTRACT section 6 keys and more)."""

    results: dict[str, Any]
    ident: Identification
    speeds: tuple[SpeedResult, ...]
    z_model: ArrC | None
    blackbox: BlackBoxComparison | None
    netlists: dict[str, str]

    def _repr_html_(self) -> str:
        """Compact summary in Jupyter (:mod:`vfmodel.report.notebook`)."""
        from vfmodel.report.notebook import reproduce_html

        return reproduce_html(self)

    def plot(self, speed_rpm: float | None = None, ax: Any = None) -> Any:
        """Measured, grey-box and BVR bearing voltage of a speed; returns the axes."""
        from vfmodel.report.notebook import reproduce_plot

        return reproduce_plot(self, speed_rpm, ax)


def netlist_text(ident: Identification, speed_rpm: float) -> str:
    """Flat ngspice netlist of the identified network at ``speed_rpm`` (no sources)."""
    sf = next(s for s in ident.speeds if s.speed_rpm == speed_rpm)
    circ = ident.spec.build(sf.params, sf.state)
    title = (f"vfmodel grey-box network at {speed_rpm:g} rpm ({sf.state}; "
             f"{ident.spec.n_sections} winding sections, {ident.spec.n_rungs} ladder rungs)")
    usage = [
        "* nodes: U V W terminals, 0 frame, SN NDE shaft end (u_B = v(SN))",
        "* bearing transfer: add e.g. 'VU U 0 AC 1' 'VV V 0 AC 0' 'VW W 0 AC 0' and '.ac ...'",
        "* impedance U-Frame: add 'IZ 0 U AC 1' and read v(U) (V, W open)",
    ]
    return to_spice(circ, title=title, extra_lines=usage)


def _remembered(fn: Callable[[ParamSet], float]) -> Callable[[ParamSet], float]:
    """``fn`` remembering its values by parameter vector: the intervals of one speed take
    the gradient of the same anchor (one network solve per point) once, not per interval."""
    memo: dict[bytes, float] = {}

    def g(p: ParamSet) -> float:
        key = p.vector.tobytes()
        if key not in memo:
            memo[key] = fn(p)
        return memo[key]

    return g


def _f(x: float) -> float | None:
    """A finite number, or None (JSON null) where it is undefined or unbounded: a relative
    error against a measured value of 0, an uncertainty the data do not bound."""
    return float(x) if np.isfinite(x) else None


def _interval(params: ParamSet, report: LogCovariance,
              quantity: Callable[[ParamSet], float], *, before: ParamSet | None,
              **anchor: Any) -> dict[str, float | None]:
    """:func:`log_interval` of ``quantity`` (``anchor``: its model-error arguments); after
    a joint fit (``before``: the stage-wise parameters) widened by the quantity's shift
    between the two fits (:func:`vfmodel.greybox.lsq.widen_interval`)."""
    iv = log_interval(params, report, quantity, **anchor)
    if before is None:
        return iv
    q0, q1 = iv["value"], float(quantity(before))
    shift = abs(float(np.log(q0 / q1))) if q0 is not None and q0 > 0 and q1 > 0 \
        else float("inf")
    return widen_interval(iv, shift)


def _whole_record_peaks(u_model: ArrF, u_meas: ArrF,
                       fs: float) -> dict[str, float | None]:
    pm, pk = peak_v(u_meas, fs, filtered=True), peak_v(u_model, fs, filtered=True)
    return {"measured_v": pm, "model_v": pk, "rel_err_pct": _f(peak_errors(pk, pm)[1])}


@capped_blas
def reproduce(dataset: Dataset, *, effects: Iterable[str] = PAPER_EFFECTS,
              sections: Sequence[int] = SECTIONS, blackbox: bool = True,
              max_nfev: int = 40, max_nfev_lubricant: int = LUBRICANT_MAX_NFEV,
              lubricant_random_starts: int = LUBRICANT_RANDOM_STARTS,
              joint: bool = JOINT_REFIT,
              progress: Progress = no_progress,
              rotating_fit: RotatingFit = "record",
              standstill_fit: StandstillFit = "combined",
              priors: bool = False,
              sections_by: SectionsBy = "spectra") -> ReproduceResult:
    """Run the paper's pipeline on ``dataset`` (see the module docstring).
    ``max_nfev``: evaluation limit of the machine stages; ``max_nfev_lubricant``: of each
    start of a lubricant stage (:data:`~vfmodel.greybox.effects.LUBRICANT_MAX_NFEV`);
    ``lubricant_random_starts``: random starts added to each lubricant stage's physical
    ones (:data:`~vfmodel.greybox.effects.LUBRICANT_RANDOM_STARTS`); ``joint``: the joint
    refit of the rotor-side machine with every rotating record
    (:data:`~vfmodel.greybox.effects.JOINT_REFIT`). ``priors``: the
    identification is maximum a posteriori with the physical priors
    (:func:`vfmodel.greybox.identify.identify`); ``model.rel_std`` is then posterior.
    ``sections_by="records"``: the winding-section count is the one among the spectra's
    choice and its neighbours whose rotating records fit best
    (:func:`vfmodel.greybox.section_choice.identify_by_records`; an identification per
    count tried); ``model.section_scores`` in results.json then holds each count's score."""
    check_choice("sections_by", sections_by, SectionsBy)
    if not dataset.impedance:
        raise InputError("reproduce needs impedance spectra", source=dataset.name,
                         expected="an [impedance] table in dataset.toml")
    if not dataset.recordings:
        raise InputError("reproduce needs recordings", source=dataset.name,
                         expected="[[recording]] entries in dataset.toml")
    id_kw: dict[str, Any] = dict(
        max_nfev=max_nfev, max_nfev_lubricant=max_nfev_lubricant,
        lubricant_random_starts=lubricant_random_starts, progress=progress, joint=joint,
        joint_trigger=0.0, rotating_fit=rotating_fit, standstill_fit=standstill_fit,
        priors=priors)
    scores: dict[int, float | None] | None = None
    if sections_by == "records":
        ident, scores = identify_by_records(dataset, effects, sections=sections, **id_kw)
    else:
        ident = identify(dataset, effects, sections=sections, **id_kw)
    eff = ident.spec.effects
    res: dict[str, Any] = {"dataset": dataset.name}
    # ---- impedance (Table II)
    z_model = None
    if ident.impedance is not None:
        t = ident.impedance
        z_model = t.model(ident.params)
        imp: dict[str, Any] = {}
        mapes, cohs = [], []
        for i, topo in enumerate(t.topologies):
            m = mape_pct(z_model[:, i], t.z_meas[:, i])
            c = coherence_coefficient(z_model[:, i], t.z_meas[:, i])
            imp[topo] = {"mape_pct": m, "coherence": c}
            mapes.append(m)
            cohs.append(c)
        imp["mean_mape_pct"] = float(np.mean(mapes))
        imp["mean_coherence"] = float(np.mean(cohs))
        res["impedance"] = imp
    # ---- bearing voltage (Table III) and baseline (Table IV)
    dc = divider_capacitances(ident.params, eff)
    bearing: dict[str, Any] = {}
    base: dict[str, Any] = {"c_wr_f": dc["c_wr"], "c_rf_f": dc["c_rf"]}
    # 95 % intervals of the divider capacitances from the last machine stage
    mach = [s for s in ident.stages if s.cov_log is not None
            and not s.name.startswith("lubricant")]
    if mach and "metallic_contact" in eff:
        # the closed contact lets the standstill data fix only C_wr times the rotor
        # current's path: that path (and what the contact hides) is known only through
        # its physics prior (vfmodel.greybox.path_prior)
        mach[-1] = with_path_prior(mach[-1], ident.params, parameter_priors(dataset, 0.0),
                                   held=STANDSTILL_HIDDEN)
    divider_iv: dict[str, Any] = {}
    if mach:
        for key in ("c_wr", "c_rf"):
            def cap(q: ParamSet, k: str = key) -> float:
                return divider_capacitances(q, eff)[k]
            divider_iv[f"{key}_f"] = _interval(ident.params, mach[-1], cap,
                                               before=ident.stagewise.get(None))
    speeds: list[SpeedResult] = []
    rel_rot, corr_all = [], []
    n_sp = len(ident.speeds)
    for k, sf in enumerate(ident.speeds):
        progress("validation", k, n_sp)
        term = sf.term
        prep = term.prep
        # rotating records fitted as waveforms carry their initial-state correction
        u_periodic = term.output(sf.params)
        u_model = (u_periodic + sf.record.transient(sf.params) if sf.record is not None
                   else u_periodic)
        # compared on the settled window (vfmodel.greybox.metrics): a record that is not
        # periodic starts from a state the periodic response does not have
        win = settled_window(prep.n_samples, prep.fs)
        pk_meas = peak_v(prep.bearing[win], prep.fs, filtered=True)
        pk_model = peak_v(u_model[win], prep.fs, filtered=True)
        abs_err, rel_err = peak_errors(pk_model, pk_meas)
        corr = spectral_corr(u_model, prep.bearing, prep.fs)
        lub = film_equivalent(sf.params, eff) if sf.state == "rotating" else \
            {"r_ohm": 0.0, "c_f": 0.0}
        key = rpm_key(sf.speed_rpm)
        h1_model = term.h1_model(sf.params)
        entry: dict[str, Any] = {
            "peak_measured_v": pk_meas, "peak_model_v": pk_model, "abs_err_v": abs_err,
            "rel_err_pct": _f(rel_err), "spectral_corr": corr,
            "spectral_corr_periodogram": spectral_corr_periodogram(u_model, prep.bearing,
                                                                   prep.fs),
            "lubricant": lub,
            "state": sf.state, "residual_rms_v": float(np.std((prep.bearing - u_model)[win])),
            "plateau_rel_err_pct": _f(plateau_rel_err_pct(u_model, prep.bearing, prep.fs,
                                                          window=win)),
            "compared_s": [win.start / prep.fs, win.stop / prep.fs],
            # CONTRACT section 6's peak over the whole record, settling margins included
            "peak_whole_record": _whole_record_peaks(u_model, prep.bearing, prep.fs),
            # the network's periodic response alone (what `predict` computes from the
            # netlist), without the initial-state correction estimated from the record
            "peak_model_periodic_v": peak_v(u_periodic[win], prep.fs, filtered=True),
        }
        if sf.report is not None:
            # 95 % intervals (delta method on the stage's posterior covariance of log p),
            # with the uncertainty of the machine the lubricant was fitted on
            rep = sf.report if not mach else with_machine_uncertainty(
                sf.record if sf.record is not None else term, sf.params, sf.report, mach[-1],
                machine_names=(*SHARED, *(n for n in STANDSTILL_HIDDEN if n not in SHARED)))
            # with the structural model error of the plateau level the record shows
            # (vfmodel.greybox.model_error), carried to each quantity by its regression
            # on that level in the speed's own stage (the parameters its fit moves; the
            # machine is held there, and the standstill data do not see the plateau)
            disc = plateau_discrepancy(prep.h1, term.op.mask, term.h_meas, h1_model)
            cm = _remembered((sf.record or term).cm_transfer)
            iv = partial(_interval, sf.params, rep, anchor=cm, anchor_tau=disc.tau,
                         anchor_report=sf.report, before=ident.stagewise.get(sf.speed_rpm))

            entry["lubricant_interval"] = {
                # the DC resistance: bounded from below only when the film's discharge
                # may be slower than the record resolves (lsq.lower_bound_only)
                "r_ohm": lower_bound_only(iv(lambda q: film_equivalent(q, eff)["r_ohm"]),
                                          iv(lambda q: film_time_constant(q, eff)),
                                          prep.n_samples / prep.fs),
                "c_f": iv(lambda q: film_equivalent(q, eff)["c_f"]),
                "c_b_f": iv(lambda q: divider_capacitances(q, eff)["c_b"]),
                "c_b_100khz_f": iv(lambda q: bearing_capacitance(q, eff)),
                # the plateau level the record fixes (identifiable without the scale)
                "cm_transfer_100khz": iv(cm),
                "model_error": disc.to_json_dict(),
            }
            entry["lubricant_params"] = {n: sf.params[n] for n in sf.report.names}
            entry["lubricant_rel_std"] = {n: _f(v) for n, v in sf.report.rel_std.items()}
        bearing[key] = entry
        if sf.state == "rotating":
            rel_rot.append(rel_err)
        corr_all.append(corr)
        # baseline
        bl = bvr_baseline(dc["c_wr"], dc["c_rf"], prep.terminals, prep.bearing)
        u_bvr = predict_bvr(bl, prep.terminals)
        pk_b = peak_v(u_bvr[win], prep.fs, filtered=True)
        _, rel_b = peak_errors(pk_b, pk_meas)
        base[key] = {"bvr": bl.bvr, "c_b_f": bl.c_b_f, "peak_model_v": pk_b,
                     "rel_err_pct": _f(rel_b), "bvr_average": bl.bvr_average,
                     "plateau_rel_err_pct": _f(plateau_rel_err_pct(u_bvr, prep.bearing,
                                                                   prep.fs, window=win))}
        # BVR(f) (Fig. 11) measured and modelled, same estimator
        tu, tv, tw = prep.terminals
        nps = prep.h1.nperseg * prep.n_samples // prep.n_h1   # same segment duration
        bm = bvr_estimate(tu, tv, tw, prep.bearing, prep.fs, nperseg=nps)
        bmod = bvr_estimate(tu, tv, tw, u_model, prep.fs, nperseg=nps)
        speeds.append(SpeedResult(
            sf.speed_rpm, prep.fs, prep.bearing, u_model, u_bvr, prep.terminals, bl,
            bm.freq_hz, bm.bvr, bmod.bvr, term.freq_hz, term.h_meas, h1_model))
    progress("validation", n_sp, n_sp)
    if rel_rot:
        bearing["mean_rel_err_pct_rotating"] = float(np.mean(rel_rot))
    bearing["mean_spectral_corr"] = float(np.mean(corr_all))
    res["bearing"] = bearing
    res["baseline_bvr"] = base
    def beats(key: str) -> bool:
        # undefined relative errors (measured peak 0) cannot show the grey box better
        g, b = bearing[key]["rel_err_pct"], base[key]["rel_err_pct"]
        return g is not None and b is not None and bool(g < b)

    res["greybox_beats_baseline"] = {rpm_key(s.speed_rpm): beats(rpm_key(s.speed_rpm))
                                     for s in speeds}
    # speeds where the classical divider predicts the peak better: flagged, not averaged
    res["flagged_speeds"] = [k for k, v in res["greybox_beats_baseline"].items() if not v]
    # ---- identification summary
    res["model"] = {
        **ident.spec.to_json_dict(),
        "params": ident.params.as_dict(),
        "rel_std": {n: _f(v) for n, v in ident.machine_rel_std.items()},
        "estimate": "maximum a posteriori (physical priors)" if priors else
                    "least squares (weak prior towards the start values)",
        "divider_intervals": divider_iv,
        "interval_method": INTERVAL_METHOD,
        "stages": [{"name": s.name, "chi2_red": s.chi2_red, "nfev": s.nfev,
                    "n_residuals": s.n_residuals, "status": s.status} for s in ident.stages],
        "speeds": {rpm_key(s.speed_rpm): {"state": s.state, "params": s.params.as_dict()}
                   for s in ident.speeds},
        "sections_by": sections_by,
    }
    if scores is not None:  # per count tried: section_choice.record_score
        res["model"]["section_scores"] = {str(n): None if v is None else _f(v)
                                          for n, v in scores.items()}
    bb = None
    if blackbox:
        bb = compare_blackbox(ident, progress=progress)
        res["blackbox"] = bb.to_json_dict()
    netlists = {f"network_{rpm_key(s.speed_rpm)}rpm.cir": netlist_text(ident, s.speed_rpm)
                for s in ident.speeds}
    return ReproduceResult(res, ident, tuple(speeds), z_model, bb, netlists)
