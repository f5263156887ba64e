"""Notebook views: compact HTML summaries (``_repr_html_``) and ``.plot()`` of the result
types. The classes keep one-line methods that call these functions, so that neither
matplotlib nor this module is imported before a notebook asks for them. ``plot`` functions
use the user's pyplot backend and return the matplotlib axes (like python-control)."""

from __future__ import annotations

from typing import Any

import numpy as np

from vfmodel.report.page import E
from vfmodel.report.units import si

__all__ = ["diagnose_html", "diagnose_plot", "fit_report_html", "fit_report_plot",
           "model_html", "model_plot", "passivity_html", "passivity_plot",
           "reproduce_html", "reproduce_plot"]

_STYLE = ("style='border-collapse:collapse;font-size:90%' ")


def _kv(title: str, rows: list[tuple[str, str]]) -> str:
    body = "".join(f"<tr><th style='text-align:left;padding:1px 8px'>{E(k)}</th>"
                   f"<td style='text-align:right;padding:1px 8px'>{v}</td></tr>"
                   for k, v in rows)
    return f"<table {_STYLE}><caption style='text-align:left'><b>{E(title)}</b></caption>" \
        f"{body}</table>"


def _axes(ax: Any, n: int = 1) -> Any:
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    _, axs = plt.subplots(n, 1, figsize=(7, 3 + 2 * (n - 1)), sharex=True, squeeze=False)
    return axs[:, 0] if n > 1 else axs[0, 0]


# ------------------------------------------------------------------ RationalModel
def model_html(m: Any) -> str:
    p = np.asarray(m.poles)
    f = np.abs(p) / (2 * np.pi)
    band = f"{si(f.min(), 'Hz')} – {si(f.max(), 'Hz')}" if p.size else "–"
    return _kv("RationalModel", [
        ("kind", E(str(m.kind))), ("ports (out × in)", f"{m.n_out} × {m.n_in}"),
        ("poles", f"{m.n_poles} ({int(np.sum(p.imag == 0))} real)"),
        ("pole frequencies", band), ("stable", "yes" if m.is_stable else "NO"),
        *([("z0", si(m.z0, "Ω"))] if getattr(m, "z0", None) else []),
        *([("delay", si(m.delay, "s"))] if getattr(m, "delay", 0.0) else [])])


def model_plot(m: Any, freq_hz: Any = None, ax: Any = None) -> Any:
    """|H| of every entry (up to 16) over ``freq_hz`` (default: a log grid around the poles)."""
    if freq_hz is None:
        f = np.abs(np.asarray(m.poles)) / (2 * np.pi)
        f = f[f > 0]
        lo, hi = (f.min() / 10, f.max() * 10) if f.size else (1.0, 1e9)
        freq_hz = np.geomspace(lo, hi, 1000)
    freq_hz = np.asarray(freq_hz, float)
    h = m(freq_hz)
    ax = _axes(ax)
    for i in range(min(m.n_out, 4)):
        for j in range(min(m.n_in, 4)):
            ax.loglog(freq_hz, np.abs(h[:, i, j]), label=f"{m.kind}{i + 1}{j + 1}")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"|{m.kind}|")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=4)
    return ax


# ------------------------------------------------------------------ FitReport
def fit_report_html(r: Any) -> str:
    return _kv("FitReport", [
        ("order", str(r.order)), ("relative RMS error", si(r.rel_rms_error)),
        ("per-point relative error RMS / max",
         f"{si(r.point_rel_rms_error)} / {si(r.point_rel_max_error)}"),
        ("noise floor", si(r.noise_floor)), ("weighting", E(str(r.weighting))),
        ("converged", "yes" if r.converged else "no"), ("why this order", E(r.order_reason)),
        *[("note", E(n)) for n in r.notes]])


def fit_report_plot(r: Any, ax: Any = None) -> Any:
    """Weighted relative RMS error of every pole-relocation iteration (by order)."""
    ax = _axes(ax)
    hist = list(r.history)
    if hist:
        ax.semilogy(range(1, len(hist) + 1), [s.weighted_rel_rms_error for s in hist], "o-",
                    ms=3, label="weighted rel. RMS error")
    if r.noise_floor:
        ax.axhline(r.noise_floor, color="k", ls="--", lw=0.8, label="noise floor")
    ax.set_xlabel("iteration")
    ax.set_ylabel("error")
    ax.set_title(f"vector fit: order {r.order}")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return ax


# ------------------------------------------------------------------ PassivityReport
def passivity_html(r: Any) -> str:
    bands = ", ".join(f"{si(lo, 'Hz')} – {si(hi, 'Hz')}" for lo, hi in r.bands_hz) or "none"
    return _kv("PassivityReport", [
        ("passive", "yes (certified)" if r.passive else "NO"), ("kind", E(str(r.kind))),
        ("method", E(str(r.method))), ("violation bands", bands),
        ("worst violation", si(r.worst_violation)),
        ("at", si(r.worst_freq_hz, "Hz")), ("stable", "yes" if r.stable else "NO"),
        ("enforcement iterations", str(r.iterations)),
        ("relative change", si(r.rel_rms_change))])


def passivity_plot(r: Any, ax: Any = None) -> Any:
    """Violation bands (shaded) and crossing frequencies on a log frequency axis."""
    ax = _axes(ax)
    f = [x for b in r.bands_hz for x in b if np.isfinite(x) and x > 0] + \
        [x for x in r.crossings_hz if x > 0]
    lo, hi = (min(f) / 10, max(f) * 10) if f else (1.0, 1e9)
    ax.set_xscale("log")
    ax.set_xlim(lo, hi)
    for b0, b1 in r.bands_hz:
        ax.axvspan(max(b0, lo), min(b1, hi), color="red", alpha=0.2)
    for x in r.crossings_hz:
        ax.axvline(x, color="k", lw=0.6)
    ax.set_yticks([])
    ax.set_xlabel("frequency (Hz)")
    ax.set_title("passive" if r.passive else f"{len(r.bands_hz)} violation band(s) "
                 f"(worst {r.worst_violation:.3g})")
    return ax


# ------------------------------------------------------------------ reproduce / diagnose
def reproduce_html(res: Any) -> str:
    r = res.results
    imp, bea = r.get("impedance", {}), r.get("bearing", {})
    return _kv(f"ReproduceResult: {r.get('dataset', '')}", [
        ("impedance MAPE (mean)", si(imp.get("mean_mape_pct"), "%")),
        ("impedance coherence (mean)", si(imp.get("mean_coherence"), "", 5)),
        ("peak error, rotating (mean)", si(bea.get("mean_rel_err_pct_rotating"), "%")),
        ("spectral correlation (mean)", si(bea.get("mean_spectral_corr"), "", 5)),
        ("speeds", E(", ".join(f"{s.speed_rpm:g}" for s in res.speeds)) + " rpm"),
        ("BVR better at", E(", ".join(r.get("flagged_speeds") or []) or "no speed"))])


def reproduce_plot(res: Any, speed_rpm: float | None = None, ax: Any = None) -> Any:
    """Measured, grey-box and BVR bearing voltage of one speed (default: the highest)."""
    sp = res.speeds[-1] if speed_rpm is None else next(
        s for s in res.speeds if s.speed_rpm == speed_rpm)
    t = np.arange(sp.u_meas.size) / sp.fs * 1e3
    ax = _axes(ax)
    ax.plot(t, sp.u_meas, lw=0.6, label="measured (10 MHz filter)")
    ax.plot(t, sp.u_model, lw=0.6, label="grey-box model")
    ax.plot(t, sp.u_bvr, lw=0.6, label="BVR model")
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("u_B (V)")
    ax.set_title(f"bearing voltage at {sp.speed_rpm:g} rpm")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    return ax


def diagnose_html(res: Any) -> str:
    d = res.document
    return _kv("DiagnoseResult", [
        ("verdict", E(str(d.get("sentence", "")))),
        ("reduced χ² start → final", f"{si(d['start']['chi2_red'])} → "
                                      f"{si(d['final']['chi2_red'])}"),
        ("mismatches", str(len(d.get("mismatches", [])))),
        ("findings", E(", ".join(f"{f['effect']} at {f['location']}"
                                 for f in d.get("findings", [])) or "none")),
        ("left beyond the noise", str(len(d.get("remaining_mismatches", []))))])


def diagnose_plot(res: Any, channel: int | None = None, ax: Any = None) -> Any:
    """|measured| and the starting and final networks of one channel (default: the first
    with a mismatch)."""
    fam, dg = res.family, res.diagnosis
    wheres = [c.where for c in fam.channels]
    if channel is None:
        mm = [m.where for m in dg.mismatches if m.where in wheres]
        channel = wheres.index(mm[0]) if mm else 0
    c = fam.channels[channel]
    p0 = fam.predict(dg.start.applied, dg.start.params)[channel]
    p1 = fam.predict(dg.final.applied, dg.final.params)[channel]
    ax = _axes(ax)
    ax.loglog(c.freq_hz, np.abs(c.measured), "k.", ms=2, label="measured")
    ax.loglog(c.freq_hz, np.abs(p0), "-", label="starting network")
    ax.loglog(c.freq_hz, np.abs(p1), "--", label="after the detective")
    ax.set_xlabel("frequency (Hz)")
    ax.set_title(c.where)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return ax
