"""Figures of ``vfmodel diagnose``: normalised residuals with the located bands shaded,
before/after overlays of every spectrum, and the pole map (``report.html``:
:mod:`vfmodel.report.diagnose_html`, re-exported here)."""

from __future__ import annotations

from functools import partial
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from vfmodel.detective.diagnose import Diagnosis, residual_by_channel
from vfmodel.detective.problem import Channel, Family
from vfmodel.greybox.objective import PreparedRecording
from vfmodel.report._mpl import draw_side_by_side, envelope, pyplot, save
from vfmodel.report.diagnose_html import write_diagnose_html

__all__ = ["write_diagnose_figures", "write_diagnose_html"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]


def _magnitude_label(where: str) -> str:
    """Axis label of a channel's magnitude: H1 transfers of the record channels (V/V; the
    common-mode current ``i_cm:`` A/V), impedances otherwise."""
    kind = where.split(":", 1)[0]
    return {"bearing": "|H1| (V/V)", "bearing_de": "|H1| (V/V)",
            "i_cm": "|H1| (A/V)"}.get(kind, "|Z| (ohm)")


def _safe(where: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in where)


def write_diagnose_figures(family: Family, d: Diagnosis, out: Path) -> list[str]:
    """Write the PNG figures to ``out``; returns their file names. The model predictions
    are computed here; the figures (two per channel, the pole map, one waveform per
    recording) are independent and drawn side by side in processes where
    :func:`vfmodel.report._mpl.draw_side_by_side` can."""
    r0 = residual_by_channel(family, d.start)
    r1 = residual_by_channel(family, d.final)
    p0 = family.predict(d.start.applied, d.start.params)
    p1 = family.predict(d.final.applied, d.final.params)
    jobs: list[partial[list[str]]] = [
        partial(_channel_figures, family.channels[k], d, r0[k], r1[k], p0[k], p1[k], out)
        for k in range(len(family.channels))]
    jobs.append(partial(_pole_map, family, d, out))
    jobs += _waveform_jobs(family, d, out)
    return draw_side_by_side(jobs)


def _channel_figures(c: Channel, d: Diagnosis, r0: ArrC, r1: ArrC, p0: ArrC, p1: ArrC,
                     out: Path) -> list[str]:
    """Residuals (start, final) and the before/after overlay of one channel."""
    plt = pyplot()
    names: list[str] = []
    f = c.freq_hz
    # residuals
    fig, axs = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    for ax, r, lab, mm in ((axs[0], r0, "starting network", d.mismatches),
                           (axs[1], r1, "after the detective", d.remaining)):
        ax.semilogx(f, r.real, ".", ms=3, label="Re (log-magnitude)")
        ax.semilogx(f, r.imag, ".", ms=3, label="Im (phase)")
        w = 16
        if f.size >= w:
            kern = np.ones(w) / w
            ax.semilogx(f[w // 2 - 1: f.size - w // 2], np.convolve(r.real, kern, "valid"),
                        "-", lw=1.5, label=f"Re, mean of {w}")
            ax.semilogx(f[w // 2 - 1: f.size - w // 2], np.convolve(r.imag, kern, "valid"),
                        "-", lw=1.5, label=f"Im, mean of {w}")
        for m in mm:
            if m.where == c.where:
                ax.axvspan(*m.band_hz, color="red", alpha=0.12)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_ylabel("residual / noise std")
        ax.set_title(f"{c.where}: {lab} (shaded: mismatch beyond noise)", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    axs[0].legend(fontsize=7, ncol=4)
    axs[1].set_xlabel("frequency (Hz)")
    name = f"residual_{_safe(c.where)}.png"
    save(fig, out / name)
    names.append(name)
    # overlays
    fig, axs = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    axs[0].loglog(f, np.abs(c.measured), "k.", ms=3, label="measured")
    axs[0].loglog(f, np.abs(p0), "-", label="starting network")
    axs[0].loglog(f, np.abs(p1), "--", label="after the detective")
    axs[1].semilogx(f, np.angle(c.measured, deg=True), "k.", ms=3)
    axs[1].semilogx(f, np.angle(p0, deg=True), "-")
    axs[1].semilogx(f, np.angle(p1, deg=True), "--")
    axs[0].set_ylabel(_magnitude_label(c.where))
    axs[1].set_ylabel("phase (deg)")
    axs[1].set_xlabel("frequency (Hz)")
    axs[0].set_title(f"{c.where}: before/after", fontsize=9)
    axs[0].legend(fontsize=8)
    for ax in axs:
        ax.grid(True, which="both", alpha=0.3)
    name = f"overlay_{_safe(c.where)}.png"
    save(fig, out / name)
    names.append(name)
    return names


def _pole_map(family: Family, d: Diagnosis, out: Path) -> list[str]:
    """Black-box poles of every channel vs the starting and final network poles."""
    bb = [c.blackbox_poles for c in family.channels if c.blackbox_poles is not None]
    try:
        net = family.poles(d.final.applied, d.final.params)
        net0 = family.poles(d.start.applied, d.start.params)
    except Exception:  # a singular network only hides the pole map
        net = net0 = np.zeros(0, complex)
    if not (bb or net.size):
        return []
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 5))
    for i, p in enumerate(bb):
        q = p / (2 * np.pi)
        ax.plot(-q.real, np.abs(q.imag), "x", label="black-box poles" if i == 0 else None)
    for q, mk, lab in ((net0, "s", "starting network"), (net, "o", "final network")):
        q = q / (2 * np.pi)
        ax.plot(-q.real, np.abs(q.imag), mk, mfc="none", label=lab)
    ax.set_xscale("log")
    ax.set_yscale("symlog", linthresh=1e3)
    ax.set_xlabel("-Re p / 2pi (Hz)")
    ax.set_ylabel("|Im p| / 2pi (Hz)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("poles: black box (what the data support) vs network", fontsize=9)
    save(fig, out / "poles.png")
    return ["poles.png"]


def _waveform_jobs(family: Family, d: Diagnosis, out: Path) -> list[partial[list[str]]]:
    """Bearing-voltage waveform figures (recording vs starting and final network), when
    the family models recordings: one job per recording, the outputs computed here."""
    outputs = getattr(family, "outputs", None)
    preps = getattr(family, "preps", ())
    if outputs is None or not preps:
        return []
    y0 = outputs(d.start.applied, d.start.params)
    y1 = outputs(d.final.applied, d.final.params)
    return [partial(_waveform, p, a, b, bool(d.findings), out)
            for p, a, b in zip(preps, y0, y1, strict=True)]


def _waveform(p: PreparedRecording, a: ArrF, b: ArrF, found: bool, out: Path) -> list[str]:
    """The whole record and a zoom where the fix changes the waveform most."""
    plt = pyplot()
    t = np.arange(p.bearing.size) / p.fs
    fig, axs = plt.subplots(2, 1, figsize=(8, 6))
    k = int(np.argmax(np.abs(a - b))) if found else int(np.argmax(np.abs(p.bearing)))
    half = min(int(10e-6 * p.fs), t.size // 2)
    z = slice(max(k - half, 0), min(k + half, t.size))
    for ax, sl in ((axs[0], slice(None)), (axs[1], z)):
        ts = t[sl] * 1e6
        ax.plot(*envelope(ts, p.bearing[sl]), color="0.6", lw=0.6,
                label="recording (10 MHz filtered)")
        ax.plot(*envelope(ts, a[sl]), "-", lw=1.0, label="starting network")
        ax.plot(*envelope(ts, b[sl]), "--", lw=1.0, label="after the detective")
        ax.set_ylabel("u_B (V)")
        ax.grid(True, alpha=0.3)
    axs[0].legend(fontsize=8)
    axs[0].set_title(f"bearing voltage at {p.speed_rpm:g} rpm (steady state from the "
                     "measured terminal voltages)", fontsize=9)
    axs[1].set_title("zoom where the added physics changes the waveform most", fontsize=9)
    axs[1].set_xlabel("time (us)")
    name = f"waveform_bearing_{p.speed_rpm:g}rpm.png"
    save(fig, out / name)
    return [name]
