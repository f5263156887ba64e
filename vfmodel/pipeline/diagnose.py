"""``diagnose`` job: run the detective on a dataset and compose ``diagnosis.json``
(CONTRACT section 7), the figures and ``report.html``.

With ``model`` (a user network, :mod:`vfmodel.detective.user_model`) the dataset directory
holds the port spectra the model names. The PMSM starting model (grey-box model minus
``without``) is not wired in yet: without ``model`` an InputError says so.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vfmodel.core.progress import Progress, no_progress
from vfmodel.detective.diagnose import Diagnosis, diagnose, impedance_mape_pct, sentence
from vfmodel.detective.fit import FitResult
from vfmodel.detective.problem import Family
from vfmodel.errors import InputError
from vfmodel.greybox.effects import EFFECT_INFO

__all__ = ["DiagnoseResult", "diagnosis_json", "run_diagnose"]


@dataclass(frozen=True)
class DiagnoseResult:
    """The detective's diagnosis, its family (data and model) and the JSON document."""

    family: Family
    diagnosis: Diagnosis
    document: dict[str, Any]


def _f(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _metrics(family: Family, fit: FitResult) -> dict[str, float | None]:
    bre = getattr(family, "bearing_rel_err_pct", None)
    return {"chi2_red": float(fit.chi2_red),
            "impedance_mape_pct": _f(impedance_mape_pct(family, fit)),
            "bearing_rel_err_pct": _f(bre(fit)) if callable(bre) else None}


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
                  "n_residuals": d.start.n_points},
        "final": {**_metrics(family, d.final), "effects_added": [
            [c.effect, c.location] for c in d.final.applied]},
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
            "impedance_mape_pct": "mean over spectra of the mean |(|Z_model|-|Z_meas|)/"
                                  "|Z_meas||*100",
        },
    }


def run_diagnose(dataset: str | Path, *, without: Iterable[str] = (),
                 model: str | Path | None = None, progress: Progress = no_progress,
                 **options: Any) -> DiagnoseResult:
    """Build the family, run :func:`vfmodel.detective.diagnose.diagnose`, compose JSON."""
    without = tuple(without)
    fam: Family
    if model is not None:
        if without:
            raise InputError("--without applies to the PMSM model; with --model the candidate "
                             "changes are the model's .effect lines", place="--without")
        from vfmodel.detective.user_model import read_user_model, user_family

        fam = user_family(read_user_model(model), dataset)
    else:
        # the PMSM family (grey-box model minus ``without`` on the six impedance topologies
        # and the recordings) is not implemented yet
        raise InputError("the PMSM starting model (--without) is not available yet in this "
                         "version; give a user network with --model FILE", place="--model")
    d = diagnose(fam, progress=progress, **options)
    return DiagnoseResult(fam, d, diagnosis_json(fam, d))
