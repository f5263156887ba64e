"""``report.html`` of ``vfmodel fit``: one self-contained page (the fit figure embedded).

Summary first: errors of the fit, passivity (certified, violated or not checked), stability,
the data's own passivity floor, what to look at (the fit's notes, a large per-point error);
then the model, the passivity details and the poles as resonances (frequency, damping,
quality factor). Numbers come from ``model.json`` (the same dictionary).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from vfmodel.core.atomic import atomic_write_text
from vfmodel.report.page import Check, E, figure, html_page, num, summary, table

__all__ = ["fit_html", "write_fit_html"]

MAX_POLE_ROWS = 60
LARGE_POINT_ERROR = 0.1
"""A per-point relative error above this is pointed out in the summary."""


def _checks(doc: dict[str, Any]) -> tuple[list[Check], list[str]]:
    pas = doc.get("passivity") or {}
    passive = doc.get("passive")
    poles = [complex(*p) for p in doc.get("poles", [])]
    stable = all(p.real < 0 for p in poles)
    checks = [
        Check("relative RMS error ‖H_model − H‖ / ‖H‖",
              num(doc.get("rel_rms_error"), "", ["rel_rms_error"]),
              (num(pas.get("unconstrained_rel_rms_error"), "",
                   ["passivity", "unconstrained_rel_rms_error"]) + " before enforcement")
              if "unconstrained_rel_rms_error" in pas else "–", "–", None),
        Check("per-point relative error, RMS / max",
              f"{num(doc.get('point_rel_rms_error'), '', ['point_rel_rms_error'])} / "
              f"{num(doc.get('point_rel_max_error'), '', ['point_rel_max_error'])}", "–",
              f"max ≤ {LARGE_POINT_ERROR:g}",
              None if doc.get("point_rel_max_error") is None
              else doc["point_rel_max_error"] <= LARGE_POINT_ERROR),
        Check("poles (order)", f"{len(poles)}", "–", "–", None),
        Check("stable (every pole in the left half plane)", "yes" if stable else "NO", "–",
              "stable", stable),
        Check("passivity", "not checked" if passive is None else
              ("certified passive" if passive else "NOT passive"), "–",
              "certified (with --passive)", passive),
    ]
    if "data_floor" in pas:
        checks.append(Check("data's own passivity violation (floor)",
                            num(pas.get("data_floor"), "", ["passivity", "data_floor"]),
                            "–", "–", None))
    look = [E(n) for n in doc.get("fit_notes", [])]
    if (doc.get("point_rel_max_error") or 0) > LARGE_POINT_ERROR:
        look.append("The largest per-point error exceeds "
                    f"{LARGE_POINT_ERROR:g}: see where the dashed error curve of the figure "
                    "rises (try --weight relative or a higher --order).")
    if passive is False:
        look.append(f"<span class='flag'>The model is not passive</span>: "
                    f"{len(pas.get('bands_hz', []))} violation band(s), see Passivity.")
    if pas.get("data_active"):
        look.append("<span class='flag'>The data themselves are active</span> (not "
                    "passive beyond the noise).")
    look.append("Order: " + E(str(doc.get("order_reason", ""))))
    return checks, look


def _poles(doc: dict[str, Any]) -> str:
    poles = [complex(*p) for p in doc.get("poles", [])]
    rows = []
    for p in sorted(poles, key=abs):
        if p.imag < 0:
            continue  # one row per conjugate pair
        w0 = abs(p)
        zeta = -p.real / w0 if w0 > 0 else 1.0
        rows.append((
            "real" if p.imag == 0 else "complex pair",
            num(w0 / (2 * math.pi), "Hz"),
            num(zeta, "", digits=3),
            num(1 / (2 * zeta), "", digits=3) if p.imag != 0 and zeta > 0 else "–"))
    shown = rows[:MAX_POLE_ROWS]
    more = (f"<p class='info'>… and {len(rows) - len(shown)} more (model.json holds all)</p>"
            if len(rows) > len(shown) else "")
    return ("<h2 id='poles'>Poles</h2><p class='note'>Natural frequency |p| / 2π, damping "
            "ratio ζ = −Re p / |p|, quality factor Q = 1 / (2ζ).</p>"
            + table(["pole", "natural frequency", "damping ζ", "Q"], shown) + more)


def _passivity(doc: dict[str, Any]) -> str:
    pas = doc.get("passivity")
    if not pas:
        return ("<h2 id='passivity'>Passivity</h2><p>Not checked (run with --passive to "
                "enforce and certify it).</p>")
    bands = pas.get("bands_hz", [])
    brow = [(str(i + 1), num(lo, "Hz", ["passivity", "bands_hz", str(i), "0"]),
             num(hi, "Hz") if hi is None else num(hi, "Hz", ["passivity", "bands_hz", str(i),
                                                              "1"]))
            for i, (lo, hi) in enumerate(bands)]
    rows = [("certified passive", "yes" if pas.get("passive") else
             "<span class='flag'>no</span>"),
            ("method", E(str(pas.get("method", "")))),
            ("worst violation", num(pas.get("worst_violation"), "",
                                    ["passivity", "worst_violation"])),
            ("at", num(pas.get("worst_freq_hz"), "Hz", ["passivity", "worst_freq_hz"])),
            ("smallest sampled margin", num(pas.get("min_margin"), "",
                                            ["passivity", "min_margin"])),
            ("enforcement iterations", E(str(pas.get("enforcement_iterations", "–")))),
            ("data passivity floor", num(pas.get("data_floor"), "", ["passivity",
                                                                    "data_floor"]))]
    notes = "".join(f"<li>{E(n)}</li>" for n in pas.get("notes", []))
    return ("<h2 id='passivity'>Passivity</h2>" + table(["", ""], rows)
            + (table(["band", "from", "to"], brow) if brow else "")
            + (f"<ul class='look'>{notes}</ul>" if notes else ""))


def fit_html(doc: dict[str, Any], figures: Sequence[str], fig_dir: Path | None = None) -> str:
    """HTML text of the report of a ``model.json`` document ``doc``."""
    checks, look = _checks(doc)
    src = ", ".join(Path(s).name for s in doc.get("sources", []))
    key_fig = figure(fig_dir, figures[0], "data (dots), model (lines) and the largest "
                     "error (dashed); click to zoom") if figures else \
        "<p class='info'>(no figure: --no-plot)</p>"
    kind = str(doc.get("kind", ""))
    sub = (f"{E(kind)} data, {doc.get('n_out')}×{doc.get('n_in')}, "
           f"{num(doc.get('freq_range_hz', [None])[0], 'Hz', ['freq_range_hz', '0'])} – "
           f"{num(doc.get('freq_range_hz', [None, None])[-1], 'Hz', ['freq_range_hz', '1'])}"
           + (f", z0 = {num(doc.get('z0'), 'Ω', ['z0'])}" if doc.get("z0") else ""))
    head = summary(f"Vector fit: {src}", sub, checks, look, key_fig, reference_name="reference")
    model_rows = [("representation", E(kind)), ("ports (out × in)",
                                                f"{doc.get('n_out')} × {doc.get('n_in')}"),
                  ("poles", str(len(doc.get("poles", [])))),
                  ("weighting", E(str(doc.get("weighting", "–")))),
                  ("common delay", num(doc.get("delay_s"), "s", ["delay_s"])),
                  ("RMS error", num(doc.get("rms_error"), "", ["rms_error"])),
                  ("relative RMS error", num(doc.get("rel_rms_error"), "", ["rel_rms_error"])),
                  ("sources", E(", ".join(doc.get("sources", []))))]
    body = [head, "<h2 id='model'>Model</h2>", table(["", ""], model_rows), _passivity(doc),
            _poles(doc)]
    if len(figures) > 1:
        body.append("<h2>Figures</h2><div class='figs'>"
                    + "".join(figure(fig_dir, f) for f in figures[1:]) + "</div>")
    return html_page(f"vfmodel fit: {src}", body)


def write_fit_html(path: Path, doc: dict[str, Any], figures: Sequence[str]) -> None:
    """Write :func:`fit_html` atomically, embedding the figures found beside ``path``."""
    atomic_write_text(path, fit_html(doc, figures, Path(path).parent))
