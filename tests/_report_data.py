"""Small stored documents and figures for the report tests (no pipeline run).

The reproduce document has the keys and magnitudes of a real ``results.json`` of
``data/pmsm40kw`` (three speeds, one failed goal, one flagged speed, parameters the data
do not determine); the diagnose document those of a ``diagnosis.json`` of the RC ladder.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np


def _iv(value: float, std_log: float | None) -> dict[str, Any]:
    if std_log is None:
        return {"value": value, "lo": None, "hi": None, "std_log": None}
    return {"value": value, "lo": value * math.exp(-1.959964 * std_log),
            "hi": value * math.exp(1.959964 * std_log), "std_log": std_log}


def _speed(peak: float, model: float, corr: float, r: float, c: float, state: str,
           std_r: float | None) -> dict[str, Any]:
    out: dict[str, Any] = {
        "peak_measured_v": peak, "peak_model_v": model, "abs_err_v": abs(model - peak),
        "rel_err_pct": 100 * abs(model - peak) / peak, "spectral_corr": corr,
        "lubricant": {"r_ohm": r, "c_f": c}, "state": state, "residual_rms_v": 0.0193,
        "plateau_rel_err_pct": 0.2235 if state == "rotating" else 86.11,
        "peak_model_periodic_v": model}
    if state == "rotating":
        out["lubricant_interval"] = {"r_ohm": _iv(r, std_r), "c_f": _iv(c, 0.0594),
                                     "c_b_f": _iv(1.69e-8, 3.9e-4),
                                     "c_b_100khz_f": _iv(1.831e-8, 4.7e-4)}
        out["lubricant_params"] = {"lubricant.R_1": r, "lubricant.C_1": 1.07e-8}
        out["lubricant_rel_std"] = {"lubricant.R_1": std_r, "lubricant.C_1": 0.135}
    return out


def reproduce_results() -> dict[str, Any]:
    """A ``results.json`` document of ``reproduce`` (values of a real run, rounded)."""
    imp: dict[str, Any] = {
        "U-Frame": {"mape_pct": 1.3861623, "coherence": 0.99960570},
        "V-Frame": {"mape_pct": 1.8665411, "coherence": 0.99895616},
        "U-V": {"mape_pct": 1.1438427, "coherence": 0.99980688}}
    topo = list(imp.values())
    imp["mean_mape_pct"] = float(np.mean([v["mape_pct"] for v in topo]))
    imp["mean_coherence"] = float(np.mean([v["coherence"] for v in topo]))
    bea: dict[str, Any] = {
        "0": _speed(0.63584995, 0.58424806, 0.85272518, 0.0, 0.0, "standstill", None),
        "100": _speed(3.0318096, 3.0437595, 0.99997641, 45148.488, 1.2399915e-08,
                      "rotating", 0.4990),
        "300": _speed(3.1049879, 2.2031437, 0.9611, 355029.91, 9.709998e-09, "rotating",
                      1.3202)}
    bea["mean_rel_err_pct_rotating"] = float(np.mean([bea[k]["rel_err_pct"]
                                                      for k in ("100", "300")]))
    bea["mean_spectral_corr"] = float(np.mean([bea[k]["spectral_corr"]
                                               for k in ("0", "100", "300")]))
    base: dict[str, Any] = {"c_wr_f": 6.055297307510336e-10, "c_rf_f": 1.1283068751653723e-09}
    for k, pk, bvr, cb in (("0", 0.04149, 0.0003025, None), ("100", 2.13714, 0.0156955,
                                                              1.8423e-08),
                           ("300", 2.42404, 0.0177637, 1.6177e-08)):
        meas = bea[k]["peak_measured_v"]
        base[k] = {"bvr": bvr, "c_b_f": cb, "peak_model_v": pk,
                   "rel_err_pct": 100 * abs(pk - meas) / meas,
                   "bvr_average": bvr if k != "0" else -7.017e-06,
                   "plateau_rel_err_pct": 4.653}
    beats = {k: bea[k]["rel_err_pct"] < base[k]["rel_err_pct"] for k in ("0", "100", "300")}
    params = {"winding.U.R_w": 0.10489678, "winding.U.L_w": 0.00047579758,
              "winding.U.C_wf": 1.2187880e-09, "insulation.R_ins": 28700735.5,
              "insulation.k_d": 0.070050396, "insulation.tau_d": 1.5519633e-06,
              "insulation.C_wr": 1.8862966e-10, "airgap.C_rf": 1.0544427e-09,
              "shaft.R_dc": 0.0010081887, "winding.skin_rho": 1.6119840, "bearing.R_h": 0.5,
              "lubricant.R_1": 50000.0,
              "lubricant.C_1": 2e-08, "fixture.L": 5e-08}
    rel = {"winding.U.R_w": 0.17966, "winding.U.L_w": 0.0037586, "winding.U.C_wf": 0.24165,
           "insulation.R_ins": 0.32178, "insulation.k_d": 0.013172,
           "insulation.tau_d": 0.027191, "insulation.C_wr": 1.5612481,
           "airgap.C_rf": 3.6328970, "shaft.R_dc": 2.7372023,
           "winding.skin_rho": 1.2e4}                  # exp(1.96 * 1.2e4) overflows
    return {
        "dataset": "pmsm40kw-bench-paper-seed0", "impedance": imp, "bearing": bea,
        "baseline_bvr": base, "greybox_beats_baseline": beats,
        "flagged_speeds": [k for k, v in beats.items() if not v],
        "model": {"effects": ["insulation_dielectric_loss", "metallic_contact"],
                  "n_rungs": 3, "n_sections": 4, "params": params, "rel_std": rel,
                  "divider_intervals": {"c_wr_f": _iv(6.055297307510336e-10, 1.5612512),
                                        "c_rf_f": _iv(1.1283068751653723e-09, 8.6e-4)},
                  "stages": [{"name": "impedance, 4 sections", "chi2_red": 13.198,
                              "nfev": 40, "n_residuals": 2451, "status": 0},
                             {"name": "lubricant 100 rpm", "chi2_red": 2.0734, "nfev": 31,
                              "n_residuals": 24432, "status": 2}]},
        "blackbox": {"bands_hz": [1e3, 1e4, 1e5, 1e6, 1e7],
                     "impedance": {"U-Frame": {"grey": [0.613, 0.536, 1.53, 2.85],
                                               "order": 8,
                                               "black": [0.303, 0.283, 0.278, 0.237]}},
                     "bearing": {"100": {"grey": [None, 0.70, 0.76, 0.52]}}},
    }


def diagnose_document() -> dict[str, Any]:
    """A ``diagnosis.json`` document (the RC ladder with a concealed dielectric loss)."""
    metrics0 = {"chi2_red": 2.1547308843200352, "impedance_mape_pct": 0.2572603862928699,
                "bearing_rel_err_pct": None}
    metrics1 = {"chi2_red": 0.9803724828095961, "impedance_mape_pct": 0.17239830769267095,
                "bearing_rel_err_pct": None}
    return {
        "mismatch_found": True,
        "mismatches": [{"where": "impedance:Zin", "band_hz": [1000.0, 1804186.4094],
                        "significance": 16.711793223020507, "p_value": 5.4e-63,
                        "statistic": "excess"}],
        "findings": [{
            "effect": "insulation_dielectric_loss", "location": "C2",
            "explanation": "Polarisation of the insulation adds a relaxation branch.",
            "signature": "phase above -90 degrees", "before": metrics0, "after": metrics1,
            "delta_bic": -921.032092309563, "heldout_delta_chi2": -411.58,
            "identifiable": True, "alternatives": [], "note": "",
            "params": {"C2.insulation_dielectric_loss.k_d": 0.12161408149593003,
                       "C2.insulation_dielectric_loss.tau_d": 2.843035955216565e-06},
            "rel_std": {"C2.insulation_dielectric_loss.k_d": 0.0394380998866136,
                        "C2.insulation_dielectric_loss.tau_d": 1.41945004149894646},
            "max_correlation": 0.94, "correlated": "k_d ~ C2"}],
        "rejected": [{"effect": "fixture_inductance", "location": "Zin",
                      "reason": "no mismatch beyond the noise is left to explain"}],
        "sentence": "insulation_dielectric_loss at C2 is missing from the network: adding it "
                    "lowers chi2_red from 2.155 to 0.980 (Delta BIC -921.0).",
        "model": "RC ladder (three sections): a non-machine network for the detective",
        "start": {**metrics0, "n_params": 6, "n_residuals": 800},
        "final": {**metrics1, "effects_added": [["insulation_dielectric_loss", "C2"]]},
        "remaining_mismatches": [],
    }


def write_png(path: Path, title: str, kind: str = "spectrum") -> str:
    """A small real figure (matplotlib, Agg) at ``path``; returns its file name."""
    from vfmodel.report._mpl import pyplot, save

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.6))
    if kind == "waveform":
        t = np.linspace(0, 1e-3, 2000)
        ax.plot(t * 1e3, 3 * np.sign(np.sin(2 * np.pi * 8e3 * t)), lw=0.8, label="measured")
        ax.set_xlabel("time (ms)")
        ax.set_ylabel("u_B (V)")
    else:
        f = np.geomspace(1e3, 1e7, 200)
        ax.loglog(f, 1 / (2 * np.pi * f * 1e-9), label="|Z|")
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel("|Z| (ohm)")
    ax.set_title(title)
    ax.legend()
    save(fig, path, dpi=80)
    return path.name
