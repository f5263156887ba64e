"""``report.html`` of ``vfmodel diagnose``: one self-contained page (figures embedded).

Summary first: the detective's sentence, the starting and final reduced chi-square, whether
a mismatch beyond the noise is left (the goal: none), what to look at; then where the
starting network disagrees, the findings with their parameters (95 % intervals), the time
windows, the rejected candidates and the figures. Numbers come from ``diagnosis.json``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from vfmodel.core.atomic import atomic_write_text
from vfmodel.report.html import MAX_STD_LOG, UNDETERMINED_STD_LOG, WEAK_STD_LOG, unit_of
from vfmodel.report.page import Check, E, figure, html_page, num, summary, table

__all__ = ["diagnose_html", "write_diagnose_html"]


def _arrow(doc: dict[str, Any], key: str, unit: str) -> str:
    a, b = doc.get("start", {}).get(key), doc.get("final", {}).get(key)
    if a is None and b is None:
        return "–"
    return f"{num(a, unit, ['start', key])} → {num(b, unit, ['final', key])}"


def _checks(doc: dict[str, Any]) -> tuple[list[Check], list[str]]:
    remaining = doc.get("remaining_mismatches", [])
    checks = [
        Check("mismatch beyond the noise (starting network)",
              f"{len(doc.get('mismatches', []))} band(s)" if doc.get("mismatch_found")
              else "none", "–", "–", None),
        Check("reduced χ², starting → final network", _arrow(doc, "chi2_red", ""),
              "≈ 1 at the noise", "–", None),
        Check("impedance MAPE, starting → final", _arrow(doc, "impedance_mape_pct", "%"),
              "–", "–", None),
        Check("bearing peak error, starting → final", _arrow(doc, "bearing_rel_err_pct", "%"),
              "–", "–", None),
        Check("effects added (findings)", str(len(doc.get("findings", []))), "–", "–", None),
        Check("final network explains the data to the noise",
              "yes" if not remaining else f"{len(remaining)} band(s) left", "–",
              "no mismatch left", not remaining),
    ]
    look = []
    for m in remaining[:6]:
        look.append(f"Still beyond the noise: <b>{E(m['where'])}</b> "
                    f"{num(m['band_hz'][0], 'Hz')} – {num(m['band_hz'][1], 'Hz')}.")
    for f in doc.get("findings", []):
        if not f.get("identifiable", True):
            alt = ", ".join(f.get("alternatives", []))
            look.append(f"<span class='flag'>⚠ {E(f['effect'])} at {E(f['location'])} is "
                        "not identifiable from these data</span>"
                        + (f" (also explained by {E(alt)})" if alt else "") + ".")
        loose = [n for n, s in (f.get("rel_std") or {}).items()
                 if s is None or s > UNDETERMINED_STD_LOG]
        if loose:
            look.append(f"Parameters of {E(f['effect'])} not determined by the data: "
                        f"{E(', '.join(loose))}.")
    ident = (doc.get("identifiability") or {}).get("effects", {})
    recs = doc.get("recommendations") or []
    for eff, status in ident.items():
        if status == "identifiable":
            continue
        first = next((r for r in recs if eff in r.get("separates", [])), None)
        found = any(f.get("effect") == eff for f in doc.get("findings", []))
        if not found and not (first is not None and first.get("decisive")):
            sf = next((r for r in recs if eff in r.get("separates", [])
                       and r.get("absorbed_by")), None)
            if sf is not None:   # the refit-aware (Shaft-Frame) one says why
                look.append(_why_unresolved(eff, status, sf))
            continue    # else a rejected effect that no measurement settles: see the table
        msg = f"{E(eff)} is {E(status)} from these data"
        if first is not None and first.get("decisive"):
            sp = first.get("speed_rpm")
            ranked = first.get("ranked_delta_chi2", first.get("expected_delta_chi2"))
            at_bound = first.get("ranked_size") == "bound"
            msg += (f"; measure <b>{E(first['measurement'])}</b>"
                    + (f" at {num(sp, 'rpm')}" if sp is not None else "")
                    + f" (expected Δχ² {num(ranked, '')}"
                    + (" for the largest size the present data allow" if at_bound else "")
                    + ")")
        look.append(msg + " (see <a href='#identifiability'>Identifiability</a>).")
    if doc.get("findings"):
        look.append("Compare the before/after overlays and residuals of the channels "
                    "with a mismatch (shaded bands).")
    elif doc.get("mismatch_found"):
        look.append("A mismatch was found but no candidate effect explains it: see the "
                    "rejected candidates and the residual figures.")
    return checks, look


def _why_unresolved(eff: str, status: str, rec: dict[str, Any]) -> str:
    """Why no offered measurement settles an effect, from its first refit-aware
    recommendation (a Shaft-Frame one with ``absorbed_by``; its first overall may be a
    channel one): at the size ranked it changes that measurement by less than the
    acceptance, or the network without it mimics it (the parameters its refit moves
    most)."""
    size = {"bound": "the largest size the present data allow",
            "prior": "its prior's typical size"}.get(rec.get("ranked_size") or "",
                                                     "its fitted size")
    sp = rec.get("speed_rpm")
    where = (f"<b>{E(rec['measurement'])}</b>"
             + (f" at {num(sp, 'rpm')}" if sp is not None else ""))
    fixed, acc = rec.get("unrefitted_delta_chi2"), rec.get("acceptance_delta_chi2")
    msg = f"{E(eff)} is {E(status)} from these data and no offered measurement separates it: "
    if fixed is not None and acc is not None and fixed <= acc:
        return msg + (f"at {size} it would change {where} by Δχ² {num(fixed, '')}, below "
                      f"the {num(acc, '')} the detective needs, even with every other value "
                      "fixed.")
    return msg + (f"at {size}, with {where} measured, the network without it would still "
                  "mimic it by moving " + ", ".join(
                      f"{E(m['parameter'])} ({num(m.get('delta_ln_p'), '')} in ln p)"
                      for m in rec["absorbed_by"]) + ".")


def _flag(s: float | None) -> str:
    if s is None or not math.isfinite(s) or s > UNDETERMINED_STD_LOG:
        return "<span class='flag'>⚠ not determined by the data</span>"
    return "<span class='weak'>weakly determined</span>" if s > WEAK_STD_LOG else ""


def _findings(doc: dict[str, Any]) -> str:
    rows, prow = [], []
    for i, f in enumerate(doc.get("findings", [])):
        key = ["findings", str(i)]
        b, a = f["before"], f["after"]
        rows.append((
            E(f["effect"]), E(f["location"]),
            f"{num(b['chi2_red'], '', [*key, 'before', 'chi2_red'])} → "
            f"{num(a['chi2_red'], '', [*key, 'after', 'chi2_red'])}",
            f"{num(b.get('impedance_mape_pct'), '%', [*key, 'before', 'impedance_mape_pct'])}"
            f" → {num(a.get('impedance_mape_pct'), '%', [*key, 'after', 'impedance_mape_pct'])}",
            f"{num(b.get('bearing_rel_err_pct'), '%', [*key, 'before', 'bearing_rel_err_pct'])}"
            f" → {num(a.get('bearing_rel_err_pct'), '%', [*key, 'after', 'bearing_rel_err_pct'])}",
            num(f.get("delta_bic"), "", [*key, "delta_bic"]),
            "yes" if f.get("identifiable", True) else "<span class='flag'>no</span>",
            f"<span class='text'>{E(f.get('explanation', ''))} {E(f.get('note', ''))}</span>"))
        for n, v in (f.get("params") or {}).items():
            u = unit_of(n)
            s = (f.get("rel_std") or {}).get(n)
            iv = ("unbounded" if s is None or not math.isfinite(s) or s > MAX_STD_LOG else
                  f"{num(v * math.exp(-1.959964 * s), u)} … "
                  f"{num(v * math.exp(1.959964 * s), u)}")
            prow.append((E(n), num(v, u, [*key, "params", n]), iv, _flag(s)))
    if not rows:
        return "<h2 id='findings'>Findings</h2><p>No effect was added.</p>"
    return ("<h2 id='findings'>Findings</h2>"
            + table(["effect", "location", "reduced χ²", "impedance MAPE",
                     "u<sub>B</sub> peak error", "Δ BIC", "identifiable", "physics"], rows)
            + ("<h3>Parameters of the added effects (95 % intervals)</h3>"
               + table(["parameter", "value", "95 % interval", ""], prow) if prow else ""))


def _mismatches(doc: dict[str, Any]) -> str:
    rows = [(E(m["where"]),
             f"{num(m['band_hz'][0], 'Hz', ['mismatches', str(i), 'band_hz', '0'])} – "
             f"{num(m['band_hz'][1], 'Hz', ['mismatches', str(i), 'band_hz', '1'])}",
             num(m["significance"], "", ["mismatches", str(i), "significance"], 3),
             E(str(m.get("statistic", ""))))
            for i, m in enumerate(doc.get("mismatches", []))]
    text = ("<h2 id='mismatches'>Where the starting network disagrees beyond the noise</h2>")
    if not rows:
        return text + "<p>Nowhere: the starting network explains the data.</p>"
    return text + table(["where", "band", "significance (z)", "test"], rows)


def _windows(doc: dict[str, Any]) -> str:
    tw = doc.get("time_windows", {}).get("start", [])[:20]
    if not tw:
        return ""
    rows = [(E(w["where"]), f"{num(w['t_s'][0], 's')} – {num(w['t_s'][1], 's')}",
             num(w["significance"], "", digits=3), num(w["rms_ratio"], "", digits=3))
            for w in tw]
    return ("<h2>Bearing-voltage time windows beyond the noise (starting network)</h2>"
            + table(["record", "time", "significance (z)", "RMS / noise RMS"], rows))


def _rejected(doc: dict[str, Any]) -> str:
    rows = [(E(r["effect"]), E(r["location"]), f"<span class='text'>{E(r['reason'])}</span>")
            for r in doc.get("rejected", [])]
    if not rows:
        return ""
    return "<h2>Rejected candidates</h2>" + table(["effect", "location", "reason"], rows)


def _band(band: Any) -> str:
    """`` (lo – hi)`` of a recommended measurement's band, or nothing."""
    if not band or band[0] is None or band[1] is None:
        return ""
    return f" ({num(band[0], 'Hz')} – {num(band[1], 'Hz')})"


def _identifiability(doc: dict[str, Any]) -> str:
    ident = doc.get("identifiability")
    recs = doc.get("recommendations")
    out = []
    if ident:
        details = ident.get("effect_details", {})
        rows = []
        for k, v in ident.get("effects", {}).items():
            why = "; ".join(f"{E(w)}: {E(d.get('reason', ''))}" for w, d in details.items()
                            if w.split(" at ")[0] == k)
            flag = E(v) if v == "identifiable" else f"<span class='flag'>{E(v)}</span>"
            rows.append((E(k), flag, f"<span class='text'>{why}</span>"))
        if rows:
            out += ["<h2 id='identifiability'>Identifiability of the effects</h2>",
                    f"<p class='text'>{E(str(ident.get('definition', '')))}</p>",
                    table(["effect", "from these data", "why"], rows)]
        params = ident.get("parameters", {})
        if params:
            count = {c: sum(1 for v in params.values() if v == c)
                     for c in ("identifiable", "prior-only", "not-identifiable")}
            std = ident.get("parameter_std_log", {})
            loose = [n for n, v in params.items() if v != "identifiable"]
            prow = [(E(n), E(params[n]), num((std.get(n) or {}).get("data"), "", digits=3),
                     num((std.get(n) or {}).get("with_prior"), "", digits=3),
                     num((std.get(n) or {}).get("prior"), "", digits=3)) for n in loose]
            out += [f"<h3>Parameters of the final network: {count['identifiable']} "
                    f"identifiable, {count['prior-only']} only through their prior, "
                    f"{count['not-identifiable']} not identifiable</h3>"]
            if prow:
                out.append(table(["parameter", "class", "std ln p (data)",
                                  "std ln p (data + prior)", "prior std ln p"], prow))
    if recs:
        rrows = [(E(r["measurement"]) + _band(r.get("band_hz"))
                  + (" with the standstill spectrum on that band" if r.get("with_standstill")
                     else ""), num(r.get("speed_rpm"), "rpm"),
                 E(", ".join(r.get("separates", []))),
                 num(r.get("expected_delta_chi2"), "", ["recommendations", str(i),
                                                       "expected_delta_chi2"]),
                 "yes" if r.get("decisive") else "no",
                 num(r.get("ranked_delta_chi2"), ""),
                 num(r.get("size_bound_share"), ""),
                 num(r.get("expected_delta_chi2_at_prior"), ""),
                 num(r.get("data_delta_chi2_at_prior"), ""),
                 num(r.get("network_spread_delta_chi2"), ""))
                for i, r in enumerate(recs)]
        out += ["<h2 id='recommendations'>Recommended measurements</h2>",
                f"<p class='text'>{E(str(doc.get('recommendations_definition', '')))}</p>",
                table(["measurement", "speed", "separates", "expected Δχ²", "decisive",
                       "Δχ² ranked by", "share of the way to the prior size (bound)",
                       "Δχ² at prior size", "prior size on present data",
                       "network's own spread (χ²)"], rrows)]
    return "".join(out)


def _implausible(doc: dict[str, Any]) -> str:
    imp = doc.get("implausible") or {}
    out = []
    for key, title in (("start", "starting network"), ("final", "final network")):
        rows = [(E(v["parameter"]), num(v.get("value"), unit_of(v["parameter"])),
                 num(v.get("z_sigma"), "σ", digits=2),
                 num(v.get("prior_median"), unit_of(v["parameter"])),
                 "<span class='text'>" + ("; ".join(
                     f"{E(x['effect'])}: {E(x['outcome'])}" for x in v["explained_by"])
                     or "no effect of the vocabulary explains it") + "</span>")
                for v in imp.get(key, [])]
        if rows:
            out += [f"<h3>Implausible values of the {title}</h3>",
                    table(["parameter", "fitted", "from prior median", "prior median",
                           "explained by (outcome)"], rows)]
    if not out:
        return ""
    return ("<h2 id='implausible'>Values far from their physical prior</h2>"
            f"<p class='text'>{E(str(imp.get('definition', '')))}</p>" + "".join(out))


def diagnose_html(doc: dict[str, Any], figures: Sequence[str],
                  fig_dir: Path | None = None) -> str:
    """HTML text of the report; the PNG ``figures`` (names in ``fig_dir``) are embedded."""
    checks, look = _checks(doc)
    where = [m["where"] for m in doc.get("mismatches", [])]
    safe = ["".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in w) for w in where]
    overlays = [f for f in figures if f.startswith("overlay_")]
    key_name = next((f"residual_{s}.png" for s in safe if f"residual_{s}.png" in figures),
                    overlays[0] if overlays else (figures[0] if figures else ""))
    key_fig = figure(fig_dir, key_name, f"{key_name}: residuals in units of the noise, "
                     "starting network (top) and after the detective (bottom); shaded: "
                     "mismatch beyond the noise (click to zoom)") if key_name else ""
    lead = f"<b>{E(str(doc.get('sentence', '')))}</b>"
    if "film_law" in doc:       # --film-law: which description of the film the data support
        lead += f"<br>{E(str(doc['film_law'].get('sentence', '')))}"
    head = summary(f"Discrepancy detective: {doc.get('model', '')}", lead, checks, look,
                   key_fig,
                   reference_name="reference")
    body = [head, _mismatches(doc), _findings(doc), _windows(doc), _identifiability(doc),
            _implausible(doc), _rejected(doc), "<h2>Figures</h2><div class='figs'>"
            + "".join(figure(fig_dir, f) for f in figures if f != key_name) + "</div>"]
    return html_page(f"vfmodel diagnose: {doc.get('model', '')}", body)


def write_diagnose_html(path: Path, doc: dict[str, Any], figures: Sequence[str]) -> None:
    """Write :func:`diagnose_html` atomically, embedding the figures found beside ``path``."""
    atomic_write_text(path, diagnose_html(doc, figures, Path(path).parent))
