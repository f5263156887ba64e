"""``diagnose`` job: run the detective on a dataset and compose ``diagnosis.json``
(CONTRACT section 7), the figures and ``report.html``.

With ``model`` (a user network, :mod:`vfmodel.detective.user_model`) the dataset directory
holds the port spectra the model names. Without it the dataset is a PMSM dataset (CONTRACT
section 2) and the starting network is the paper's grey-box model minus ``without``
(:mod:`vfmodel.detective.pmsm`); the bearing-voltage waveforms are then compared in time
windows too (:mod:`vfmodel.detective.windows`).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vfmodel.core.blas import capped_blas
from vfmodel.core.progress import Progress, no_progress
from vfmodel.detective.diagnose import Diagnosis, diagnose, impedance_mape_pct, sentence
from vfmodel.detective.fit import FitResult
from vfmodel.detective.problem import Family, channel_slices
from vfmodel.errors import InputError
from vfmodel.greybox.effects import EFFECT_INFO

__all__ = ["DiagnoseResult", "chi2_per_channel", "diagnosis_json", "identifiability_json",
           "implausible_json", "run_diagnose"]


@dataclass(frozen=True)
class DiagnoseResult:
    """The detective's diagnosis, its family (data and model) and the JSON document."""

    family: Family
    diagnosis: Diagnosis
    document: dict[str, Any]

    def _repr_html_(self) -> str:
        """Compact summary in Jupyter (:mod:`vfmodel.report.notebook`)."""
        from vfmodel.report.notebook import diagnose_html

        return diagnose_html(self)

    def plot(self, channel: int | None = None, ax: Any = None) -> Any:
        """Measured vs starting and final network of a channel; returns the axes."""
        from vfmodel.report.notebook import diagnose_plot

        return diagnose_plot(self, channel, ax)


def _f(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _metrics(family: Family, fit: FitResult) -> dict[str, float | None]:
    bre = getattr(family, "bearing_rel_err_pct", None)
    return {"chi2_red": float(fit.chi2_red),
            "impedance_mape_pct": _f(impedance_mape_pct(family, fit)),
            "bearing_rel_err_pct": _f(bre(fit)) if callable(bre) else None}


def chi2_per_channel(family: Family, fit: FitResult) -> dict[str, float]:
    """Mean squared normalised residual per residual entry of each channel (the share of
    the misfit a channel carries; ~1 at the noise)."""
    return {c.where: float(fit.residual[sl] @ fit.residual[sl]) / (2 * c.n)
            for c, sl in zip(family.channels, channel_slices(family.channels), strict=True)}


def diagnosis_json(family: Family, d: Diagnosis) -> dict[str, Any]:
    """``diagnosis.json`` document (CONTRACT section 7 keys plus details)."""
    findings = []
    for f in d.findings:
        c = f.candidate
        findings.append({
            "effect": c.effect, "location": c.location,
            "explanation": EFFECT_INFO[c.effect].explanation,
            "signature": EFFECT_INFO[c.effect].signature,
            "before": _metrics(family, f.before), "after": _metrics(family, f.after),
            "delta_bic": float(f.trial.delta_bic),
            "heldout_delta_chi2": float(f.trial.heldout_delta_chi2),
            "identifiable": bool(f.identifiable), "alternatives": list(f.alternatives),
            "note": f.note,
            "params": {s.name: float(f.after.params[s.name]) for s in c.params},
            "rel_std": {k: _f(v) for k, v in f.trial.new_rel_std.items()},
            "max_correlation": float(f.trial.max_corr), "correlated": f.trial.corr_with,
        })
    return {
        "mismatch_found": bool(d.mismatch_found),
        "mismatches": [{"where": m.where, "band_hz": [m.band_hz[0], m.band_hz[1]],
                        "significance": float(m.significance), "p_value": float(m.p_value),
                        "statistic": m.statistic} for m in d.mismatches],
        "findings": findings,
        "rejected": [{"effect": c.effect, "location": c.location, "reason": why}
                     for c, why in d.rejected],
        "sentence": sentence(d),
        "model": d.family,
        "start": {**_metrics(family, d.start), "n_params": d.start.k,
                  "n_residuals": d.start.n_points,
                  "chi2_per_channel": chi2_per_channel(family, d.start)},
        "final": {**_metrics(family, d.final), "effects_added": [
            [c.effect, c.location] for c in d.final.applied],
                  "chi2_per_channel": chi2_per_channel(family, d.final)},
        "remaining_mismatches": [{"where": m.where, "band_hz": list(m.band_hz),
                                  "significance": float(m.significance)} for m in d.remaining],
        "noise": {c.where: {"sigma_log": float(np.median(c.sigma)), "method": c.noise_method}
                  for c in family.channels},
        "poles": {"start": [p.summary() for p in d.poles_start],
                  "final": [p.summary() for p in d.poles_final]},
        "definitions": {
            "chi2_red": "sum of squared noise-normalised residuals (Re and Im of "
                        "log(model/measured) divided by the estimated noise std) over the "
                        "number of residuals minus fitted parameters",
            "significance": "Bonferroni-corrected p-value of the band as a one-sided "
                            "Gaussian z score",
            "statistic": "the test that shows the band: 'bias' or 'excess' of the "
                         "residual in a window of points; 'candidate' when no window does "
                         "and a candidate's chi-square gain is significant (likelihood "
                         "ratio, Bonferroni over the candidates tried) and repeated on the "
                         "held-out points (the band is the channel that holds most of the "
                         "gain)",
            "impedance_mape_pct": "mean over spectra of the mean |(|Z_model|-|Z_meas|)/"
                                  "|Z_meas||*100",
            "chi2_per_channel": "per channel, the sum of its squared noise-normalised "
                                "residuals over its number of residuals (no parameter "
                                "correction)",
        },
    }


PMSM_OPTIONS: dict[str, Any] = {"max_nfev": 30, "heldout_nfev": 6, "n_starts": 1}
"""Detective options for the PMSM family: its start is the staged grey-box identification
(not a raw nominal start), so one start suffices; refits are warm-started."""


def bearing_windows(family: Family, fit: FitResult, speeds: Iterable[str] | None = None
                    ) -> list[dict[str, Any]]:
    """Time windows of the bearing-voltage records where ``fit`` disagrees beyond the noise
    (only the records named in ``speeds``, e.g. ``"bearing:100rpm"``; default all)."""
    from vfmodel.detective.windows import noise_variance, time_windows
    from vfmodel.signals.filters import F_CUT_HZ

    outputs = getattr(family, "outputs", None)
    preps = getattr(family, "preps", ())
    if outputs is None or not preps:
        return []
    ys = outputs(fit.applied, fit.params)
    recs = []
    for y, p in zip(ys, preps, strict=True):
        where = f"bearing:{p.speed_rpm:g}rpm"
        if speeds is not None and where not in set(speeds):
            continue
        recs.append((where, p.bearing - y, p.fs, noise_variance(p.h1, F_CUT_HZ)))
    return [{"where": w.where, "t_s": [w.t_s[0], w.t_s[1]], "significance": w.significance,
             "rms_ratio": w.rms_ratio}
            for w in time_windows(recs, bandwidth_hz=F_CUT_HZ)]


def _have(ds: Any) -> set[tuple[str, float]]:
    """Further measurements (CONTRACT section 2a) the dataset already holds (a shaft-to-frame
    spectrum reaching half of the wide band's upper end counts as the wide-band one too,
    :data:`vfmodel.detective.recommend.WIDE`)."""
    from vfmodel.detective.recommend import WIDE, WIDE_F_HI_HZ

    spectra = [(0.0, "Shaft-Frame", ds.further_impedance["Shaft-Frame"])] \
        if "Shaft-Frame" in ds.further_impedance else []
    spectra += [(float(s.speed_rpm), s.topology, s.data) for s in ds.impedance_at_speed]
    have = {(f"impedance:{t}", rpm) for rpm, t, _ in spectra}
    have |= {(WIDE, rpm) for rpm, t, fd in spectra
             if t == "Shaft-Frame" and float(fd.freq_hz[-1]) >= 0.5 * WIDE_F_HI_HZ}
    for r in ds.recordings:
        have |= {(f"channel:{c}", float(r.speed_rpm or 0.0)) for c in r.extra_channels}
    return have


def identifiability_json(family: Family, d: Diagnosis, dataset: Any = None) -> dict[str, Any]:
    """``identifiability`` and ``recommendations`` of ``diagnosis.json`` (CONTRACT section
    7): :func:`vfmodel.detective.identifiability.assess` with the physical priors of the
    grey-box parameters (PMSM datasets; a user network has none) and
    :func:`vfmodel.detective.recommend.recommend` for every effect that is not
    identifiable, rejected or ambiguous."""
    from vfmodel.detective.identifiability import assess, grey_box_priors
    from vfmodel.detective.recommend import comparisons, recommend

    names = {n for fit in (d.final, *(t.fit for r in d.trials for t in r)) for n in fit.names}
    priors = grey_box_priors(sorted(names), dataset) if dataset is not None else {}
    a = assess(family, d, {n: p.sigma for n, p in priors.items()})
    status = {k: v.status for k, v in a.effects.items()}
    und = {k: v.undetermined for k, v in a.effects.items()}
    cov = a.parameters.cov_post
    recs = recommend(family, comparisons(d, status, und, priors),
                     have=_have(dataset) if dataset is not None else (),
                     network=(d.final, cov) if cov is not None else None,
                     prior_sigma={n: p.sigma for n, p in priors.items()}
                     if dataset is not None else None)
    return {"identifiability": a.as_json(),
            "recommendations": [r.as_json() for r in recs],
            "recommendations_definition": (
                "expected_delta_chi2: sum over the would-be measured points of "
                "|model with - model without|^2 / sigma^2, both fitted networks simulated "
                "on the measurement (impedance: ln Z with the noise of the dataset's own "
                "spectra; channels: H1 from the terminal voltages whitened by the measured "
                "u_B H1 covariance at that speed, i_CM at the SNR of u_B); the network "
                "with the effect at its fitted values against the same network without "
                "it; *_at_prior: the effect's undetermined parameters at their prior "
                "median (data_delta_chi2_at_prior: what that size costs on the data "
                "already measured); each effect keeps its most separating speed per "
                "measurement; decisive: above 10 + k ln m (the detective's acceptance); "
                "network_spread_delta_chi2: expected chi2 of the measurement from the final "
                "network's own uncertainty (covariance of ln p from data and prior), i.e. "
                "what it would teach the network whatever the effect (Shaft-Frame only); "
                "expected_delta_chi2_after_refit (Shaft-Frame only): what the network "
                "without the effect, refitted (linearised, held by the physical priors) to "
                "the network with it on the present data and the measurement, still misses "
                "on top of what it misses without the measurement (_at_prior: towards the "
                "network with the effect's undetermined parameters at their prior median); "
                "where given, decisive and the ranking use the larger of the two, the "
                "latter only when the refit absorbs that size on the present data "
                "(prior_size_open), else at the largest size those data allow "
                "(_at_bound: the undetermined parameters moved towards their prior median, "
                "in ln p, as far as that refit still misses the present data by at most the "
                "detective's acceptance; size_bound_share: the share of the way); "
                "ranked_delta_chi2: the value decisive and the ranking use; absorbed_by "
                "(Shaft-Frame only): the parameters that refit moves most (change of ln p) "
                "at the size ranked, i.e. what mimics the effect on that measurement; "
                "unrefitted_delta_chi2: the separation at that size with every other value "
                "fixed; acceptance_delta_chi2: 10 + k ln m of that measurement; "
                "null: not finite or not computed")}


def implausible_json(family: Any, d: Diagnosis, dataset: Any) -> dict[str, Any]:
    """``implausible`` of ``diagnosis.json``: the fitted values of the starting and the
    final network far from their physical priors, with the effects that explain them and
    what the detective found (:mod:`vfmodel.detective.evidence`)."""
    from vfmodel.detective.evidence import N_SIGMA, implausible_evidence
    from vfmodel.detective.identifiability import grey_box_priors

    found = {f.candidate.effect: f.candidate.location for f in d.findings}
    rejected = {c.effect: why for c, why in d.rejected}
    out: dict[str, Any] = {"definition": f"fitted values more than {N_SIGMA:g} geometric "
                           "sigmas of their physical prior from its median "
                           "(vfmodel.greybox.priors), each with the effects of the "
                           "vocabulary that explain such a value and their outcome"}
    priors = grey_box_priors(sorted({*d.start.names, *d.final.names}), dataset)
    for key, fit in (("start", d.start), ("final", d.final)):
        vals = {n: fit.params[n] for n in fit.names}
        out[key] = implausible_evidence(vals, priors, family.spec(fit.applied).effects,
                                        found, rejected)
    return out


def film_law_sentence(doc: dict[str, Any]) -> str:
    """The sentence of ``diagnosis.json``'s ``film_law`` (which description the data
    support)."""
    c = doc["comparison"]
    law = ", ".join(f"{n.split('.')[-1]} ~ speed^{v['exponent']:+.2f}"
                    + (f" (std {v['exponent_std']:.2g}" if v["exponent_std"] is not None
                       else " (std -")
                    + ("" if v["determined"] else ", not determined by the data") + ")"
                    for n, v in doc["power"].items())
    d = c["delta_bic_law_minus_free"]
    which = ("the film law" if c["supported"] == "law"
             else "free per-speed film values")
    return (f"Film law across speeds ({law}; n_ref {doc['n_ref_rpm']:.4g} rpm): the data "
            f"support {which} ({c['strength']}: BIC law {c['law']['bic']:.1f} with "
            f"{c['law']['k']} parameters, free {c['free']['bic']:.1f} with "
            f"{c['free']['k']}, Delta BIC {d:+.1f}; chi2_red {c['law']['chi2_red']:.3f} "
            f"vs {c['free']['chi2_red']:.3f}).")


@capped_blas
def run_diagnose(dataset: str | Path, *, without: Iterable[str] = (),
                 model: str | Path | None = None, priors: bool = False,
                 film_law: bool = False, progress: Progress = no_progress,
                 **options: Any) -> DiagnoseResult:
    """Build the family, run :func:`vfmodel.detective.diagnose.diagnose`, compose JSON.

    PMSM model only: ``priors``, maximum a posteriori refits with the physical priors
    (:func:`vfmodel.detective.pmsm.pmsm_family`); ``film_law``, the film follows a law in
    speed (:mod:`vfmodel.detective.film_law`) and ``diagnosis.json`` gets ``film_law``: the
    fitted law and its comparison with free per-speed values on the final network (BIC)."""
    without = tuple(without)
    fam: Family
    ds = None
    if model is not None:
        if without:
            raise InputError("--without applies to the PMSM model; with --model the candidate "
                             "changes are the model's .effect lines", place="--without")
        if priors:
            raise InputError("applies to the PMSM model only (its parameters have physical "
                             "priors); a --model network has none", place="--priors")
        if film_law:
            raise InputError("applies to the PMSM model's lubricant film, not to a --model "
                             "network", place="--film-law")
        from vfmodel.detective.user_model import read_user_model, user_family

        fam = user_family(read_user_model(model), dataset, source=str(model))
    else:
        from vfmodel.core.io_dataset import read_dataset
        from vfmodel.detective.pmsm import pmsm_family

        ds = read_dataset(dataset)
        fam = pmsm_family(ds, without, priors=priors, film_law=film_law, progress=progress)
        options = {**PMSM_OPTIONS, **options}
    d = diagnose(fam, progress=progress, **options)
    doc = diagnosis_json(fam, d)
    law = getattr(fam, "law", None)
    if law is not None:
        from vfmodel.detective.film_law import compare_free, film_law_json

        progress("film law against free per-speed values", 0, 1)
        fl = film_law_json(law, d.final)
        fl["comparison"] = compare_free(fam, d.final,
                                        max_nfev=int(options.get("max_nfev", 30)))
        fl["sentence"] = film_law_sentence(fl)
        fl["definition"] = (
            "the final network fitted with the film law (power laws of lubricant.C_1 "
            "and lubricant.R_1 in speed about n_ref, one lubricant.k_d and tau_d for every "
            "speed; the rest per speed) and refitted, warm-started, with free per-speed "
            "values; BIC = chi2 + k ln m on the same m residuals; supported: the lower BIC "
            "(very strong: difference > 10); exponent: d ln value / d ln speed, std from "
            "the Gauss-Newton covariance")
        doc["film_law"] = fl
        progress("film law against free per-speed values", 1, 1)
    progress("identifiability and recommendations", 0, 1)
    doc.update(identifiability_json(fam, d, ds))
    if ds is not None:
        doc["implausible"] = implausible_json(fam, d, ds)
    progress("identifiability and recommendations", 1, 1)
    if getattr(fam, "preps", ()):
        flagged = {m.where.rsplit(":", 1)[0] for m in d.mismatches
                   if m.where.startswith("bearing:")}
        doc["time_windows"] = {"start": bearing_windows(fam, d.start, flagged),
                               "final": bearing_windows(fam, d.final, flagged),
                               "definition": "intervals of the 10 MHz-filtered bearing "
                               "voltage where model minus recording exceeds the "
                               "non-coherent (noise) power of the H1 analysis; only for "
                               "records whose H1 transfer shows a mismatch"}
    return DiagnoseResult(fam, d, doc)
