"""A self-contained ``report.html`` of ``vfmodel reproduce``: tables and ``<img>`` figures."""

from __future__ import annotations

import html
import itertools
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from vfmodel.core.atomic import atomic_write_text

__all__ = ["reproduce_html", "write_reproduce_html"]

_CSS = """body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:3px 8px;
text-align:right}th{background:#eee}td:first-child{text-align:left}
img{max-width:100%;border:1px solid #ddd;margin:0.5em 0}.ok{color:#070}.bad{color:#a00}
.warn{color:#a00}"""


def _fmt(x: Any, digits: int = 4) -> str:
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    return html.escape(str(x))


def _table(head: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    h = "".join(f"<th>{html.escape(c)}</th>" for c in head)
    body = "".join("<tr>" + "".join(f"<td>{_fmt(v)}</td>" for v in r) + "</tr>" for r in rows)
    return f"<table><tr>{h}</tr>{body}</table>"


def reproduce_html(results: dict[str, Any], figures: Sequence[str]) -> str:
    """HTML text of the report (figures referenced by relative file name)."""
    parts = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>vfmodel reproduce: "
             f"{html.escape(str(results.get('dataset', '')))}</title><style>{_CSS}</style>"
             "</head><body>",
             f"<h1>Grey-box bearing-voltage model: {html.escape(str(results.get('dataset')))}"
             "</h1>"]
    imp = results.get("impedance", {})
    if imp:
        rows: list[Sequence[Any]] = [(k, v["mape_pct"], v["coherence"])
                                     for k, v in imp.items() if isinstance(v, dict)]
        rows.append(("mean", imp["mean_mape_pct"], imp["mean_coherence"]))
        parts += ["<h2>Impedance spectra (condition 1, paper Table II)</h2>",
                  _table(["topology", "MAPE (%)", "coherence coefficient"], rows)]
    bea = results.get("bearing", {})
    base = results.get("baseline_bvr", {})
    if bea:
        rows = []
        for k, v in bea.items():
            if not isinstance(v, dict):
                continue
            b = base.get(k, {})
            beats = results.get("greybox_beats_baseline", {}).get(k)
            rows.append((k, v["peak_measured_v"], v["peak_model_v"], v["abs_err_v"],
                         v["rel_err_pct"], v["spectral_corr"], v.get("plateau_rel_err_pct"),
                         b.get("peak_model_v"), b.get("rel_err_pct"),
                         b.get("plateau_rel_err_pct"),
                         "-" if beats is None else ("yes" if beats else "NO (flagged)")))
        flagged = results.get("flagged_speeds") or []
        parts += ["<h2>Bearing voltage (condition 2, paper Tables III and IV)</h2>",
                  _table(["speed (rpm)", "peak measured (V)", "peak grey box (V)",
                          "abs. error (V)", "rel. error (%)", "spectral corr.",
                          "plateau error (%)", "peak BVR model (V)", "BVR rel. error (%)",
                          "BVR plateau error (%)", "grey box better than BVR"], rows),
                  "<p>plateau error: relative RMS error of the bearing voltage below "
                  "200 kHz (the capacitive-divider step after each edge and the level "
                  "between edges).</p>",
                  ("<p class='warn'><b>The classical BVR model predicts the peak better at "
                   f"{', '.join(html.escape(str(x)) for x in flagged)} rpm.</b></p>"
                   if flagged else ""),
                  "<p>mean relative peak error (rotating): "
                  f"{_fmt(bea.get('mean_rel_err_pct_rotating'))} %; mean spectral "
                  f"correlation: {_fmt(bea.get('mean_spectral_corr'))}</p>"]
        rows = [(k, v["lubricant"]["r_ohm"], v["lubricant"]["c_f"], v.get("state"))
                for k, v in bea.items() if isinstance(v, dict)]
        parts += ["<h3>Lubricant film (equivalent R and C of one bearing)</h3>",
                  _table(["speed (rpm)", "R (ohm)", "C (F)", "state"], rows)]
    if base:
        rows = [(k, v["bvr_average"], v["bvr"], v["c_b_f"]) for k, v in base.items()
                if isinstance(v, dict)]
        parts += ["<h3>Classical BVR model</h3>",
                  f"<p>C_wr = {_fmt(base.get('c_wr_f'))} F, C_rf = {_fmt(base.get('c_rf_f'))} F "
                  "(from the identified network)</p>",
                  _table(["speed (rpm)", "average BVR", "model BVR", "C_b (F)"], rows)]
    model = results.get("model", {})
    if model:
        rows = [(s["name"], s["chi2_red"], s["nfev"], s["n_residuals"])
                for s in model.get("stages", [])]
        parts += ["<h2>Identification</h2>",
                  f"<p>winding sections: {model.get('n_sections')}, ladder rungs: "
                  f"{model.get('n_rungs')}, effects: "
                  f"{html.escape(', '.join(model.get('effects', [])))}</p>",
                  _table(["stage", "reduced chi-square", "evaluations", "residuals"], rows)]
        rel = model.get("rel_std", {})
        rows = [(n, v, rel.get(n)) for n, v in model.get("params", {}).items() if n in rel]
        parts += ["<h3>Machine parameters</h3>",
                  _table(["parameter", "value", "relative std. uncertainty"], rows)]
    bb = results.get("blackbox")
    if bb:
        edges = bb["bands_hz"]
        bands = [f"{lo:.0e}-{hi:.0e} Hz" for lo, hi in itertools.pairwise(edges)]
        for title, key in (("impedance MAPE (%) per band", "impedance"),
                           ("bearing transfer relative RMS error per band", "bearing")):
            rows = []
            for k, v in bb[key].items():
                rows.append([f"{k} grey", *v["grey"]])
                if "black" in v:
                    rows.append([f"{k} black (order {v.get('order')})", *v["black"]])
            parts += [f"<h3>Black box vs grey box: {title}</h3>", _table(["", *bands], rows)]
    parts.append("<h2>Figures</h2>")
    parts += [f"<p><img src='{html.escape(f)}' alt='{html.escape(f)}'></p>" for f in figures]
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def write_reproduce_html(path: Path, results: dict[str, Any], figures: Sequence[str]) -> None:
    """Write :func:`reproduce_html` atomically."""
    atomic_write_text(path, reproduce_html(results, figures))
