"""Figures of ``vfmodel reproduce`` (like the reference paper's Figs. 11 and 19-25).

Every function writes one PNG (atomically) and returns its file name.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from vfmodel.greybox.metrics import settled_window
from vfmodel.pipeline.reproduce import ReproduceResult, SpeedResult, rpm_key
from vfmodel.report._mpl import draw_side_by_side, envelope, pyplot, save
from vfmodel.signals.filters import F_CUT_HZ

__all__ = ["write_figures"]


def _impedance(res: ReproduceResult, out: Path, group: str) -> str | None:
    t = res.ident.impedance
    if t is None or res.z_model is None:
        return None
    sel = [i for i, n in enumerate(t.topologies) if ("Frame" in n) == (group == "CM")]
    if not sel:
        return None
    plt = pyplot()
    fig, (am, ap) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    for i in sel:
        lab = t.topologies[i]
        line = am.loglog(t.freq_hz, np.abs(t.z_meas[:, i]), ".", ms=2, label=f"{lab} measured")
        c = line[0].get_color()
        am.loglog(t.freq_hz, np.abs(res.z_model[:, i]), "-", color=c, lw=1,
                  label=f"{lab} model")
        ap.semilogx(t.freq_hz, np.degrees(np.angle(t.z_meas[:, i])), ".", ms=2, color=c)
        ap.semilogx(t.freq_hz, np.degrees(np.angle(res.z_model[:, i])), "-", color=c, lw=1)
    am.set_ylabel("|Z| (ohm)")
    ap.set_ylabel("phase (deg)")
    ap.set_xlabel("frequency (Hz)")
    am.set_title(f"{group} impedance: measured (dots) and grey-box model (lines)")
    am.legend(fontsize=7, ncol=2)
    for a in (am, ap):
        a.grid(True, which="both", alpha=0.3)
    name = f"fig19_impedance_{group.lower()}.png"
    save(fig, out / name)
    return name


def _zoom_window(s: SpeedResult, width_s: float = 6e-6) -> tuple[int, int]:
    w = settled_window(s.u_meas.size, s.fs)      # where the peaks are compared
    k = w.start + int(np.argmax(np.abs(s.u_meas[w])))
    n = max(int(width_s * s.fs), 16)
    a = max(0, k - n // 3)
    return a, min(s.u_meas.size, a + n)


def _bearing(s: SpeedResult, out: Path, baseline: bool) -> str:
    plt = pyplot()
    t = np.arange(s.u_meas.size) / s.fs
    a, b = _zoom_window(s)
    fig, (ao, az) = plt.subplots(2, 1, figsize=(9, 7))
    ao.plot(*envelope(t * 1e3, s.u_meas), lw=0.6, label="measured (10 MHz filter)")
    ao.plot(*envelope(t * 1e3, s.u_model), lw=0.6, label="grey-box model")
    if baseline:
        ao.plot(*envelope(t * 1e3, s.u_bvr), lw=0.6,
                label=f"BVR model ({100 * s.baseline.bvr:.3g} %)")
    w = settled_window(s.u_meas.size, s.fs)
    for lo, hi in ((0.0, w.start / s.fs), (w.stop / s.fs, s.u_meas.size / s.fs)):
        ao.axvspan(lo * 1e3, hi * 1e3, color="0.85", lw=0)
    ao.set_xlabel("time (ms); grey: not compared (record start and end)")
    ao.set_ylabel("u_B (V)")
    ao.set_title(f"bearing voltage at {s.speed_rpm:g} rpm: overall")
    az.plot(t[a:b] * 1e6, s.u_meas[a:b], lw=1, label="measured")
    az.plot(t[a:b] * 1e6, s.u_model[a:b], lw=1, label="grey-box model")
    if baseline:
        az.plot(t[a:b] * 1e6, s.u_bvr[a:b], lw=1, label="BVR model")
    az.set_xlabel("time (us)")
    az.set_ylabel("u_B (V)")
    az.set_title("detail around the largest measured transient")
    for ax in (ao, az):
        ax.grid(True, alpha=0.3)
    # a fixed place over the whole record: matplotlib's "best" tests every one of its
    # ~10^5 points (3 s of the report)
    ao.legend(fontsize=7, loc="upper right")
    az.legend(fontsize=7)
    fig.tight_layout()
    name = (f"fig24_25_baseline_{rpm_key(s.speed_rpm)}rpm.png" if baseline
            else f"fig20_22_bearing_{rpm_key(s.speed_rpm)}rpm.png")
    save(fig, out / name)
    return name


def _bvr_f(s: SpeedResult, out: Path) -> str:
    plt = pyplot()
    fig, (am, ap) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    sel = (s.bvr_freq_hz > 0) & (s.bvr_freq_hz <= F_CUT_HZ)
    f = s.bvr_freq_hz[sel]
    am.loglog(f, np.abs(s.bvr_meas[sel]), ".", ms=2, label="measured (H1)")
    am.loglog(f, np.abs(s.bvr_model[sel]), "-", lw=1, label="grey-box model (same estimator)")
    ap.semilogx(f, np.degrees(np.angle(s.bvr_meas[sel])), ".", ms=2)
    ap.semilogx(f, np.degrees(np.angle(s.bvr_model[sel])), "-", lw=1)
    am.set_ylabel("|BVR(f)|")
    ap.set_ylabel("phase (deg)")
    ap.set_xlabel("frequency (Hz)")
    am.set_title(f"frequency-dependent BVR at {s.speed_rpm:g} rpm (paper Fig. 11)")
    am.legend(fontsize=8)
    for a in (am, ap):
        a.grid(True, which="both", alpha=0.3)
    name = f"fig11_bvr_{rpm_key(s.speed_rpm)}rpm.png"
    save(fig, out / name)
    return name


def _lubricant(res: ReproduceResult, out: Path) -> str | None:
    b: Any = res.results["bearing"]
    rows = sorted(((float(k), v) for k, v in b.items()
                   if isinstance(v, dict) and v.get("state") == "rotating"), key=lambda t: t[0])
    if not rows:
        return None
    plt = pyplot()
    fig, (ar, ac) = plt.subplots(1, 2, figsize=(10, 4))
    sp = [k for k, _ in rows]
    ar.semilogy(sp, [v["lubricant"]["r_ohm"] for _, v in rows], "o-", label="fitted")
    # the 95 % bounds of results.json: two-sided where the record resolves the film's
    # discharge, the lower end alone where it may be slower (lsq.lower_bound_only)
    ivs = [(k, v.get("lubricant_interval", {}).get("r_ohm") or {}) for k, v in rows]
    lo = [(k, iv["lo"]) for k, iv in ivs if iv.get("lo") is not None]
    hi = [(k, iv["hi"]) for k, iv in ivs if iv.get("hi") is not None]
    if lo:
        ar.plot(*zip(*lo, strict=True), "^", color="C2", label="95 % lower bound")
    if hi:
        ar.plot(*zip(*hi, strict=True), "v", color="C3", label="95 % upper bound")
    if lo or hi:
        ar.legend(fontsize=8)
    ac.plot(sp, [v["lubricant"]["c_f"] * 1e9 for _, v in rows], "o-")
    ar.set_title("equivalent film resistance")
    ar.set_ylabel("R (ohm)")
    ac.set_title("equivalent film capacitance")
    ac.set_ylabel("C (nF)")
    for a in (ar, ac):
        a.set_xlabel("speed (rpm)")
        a.grid(True, which="both", alpha=0.3)
    name = "fig23_lubricant.png"
    save(fig, out / name)
    return name


def _matrix(table: dict[str, Any], key: str, n: int) -> Any:
    rows = [[np.nan if v is None else float(v) for v in e.get(key, [None] * n)]
            for e in table.values()]
    return np.asarray(rows, dtype=float).reshape(len(rows), n)


def _colmean(a: Any) -> Any:
    """Column means ignoring NaN (0 for an all-NaN column, i.e. an empty band)."""
    ok = np.isfinite(a)
    return np.where(ok, a, 0.0).sum(axis=0) / np.maximum(ok.sum(axis=0), 1)


def _blackbox(res: ReproduceResult, out: Path) -> list[str]:
    bb = res.blackbox
    if bb is None:
        return []
    plt = pyplot()
    names = []
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    centres = [f"{lo:.0e}-{hi:.0e}" for lo, hi in zip(bb.bands_hz[:-1], bb.bands_hz[1:],
                                                       strict=True)]
    x = np.arange(len(centres))
    for ax, (title, table, unit) in zip(axes, (
            ("impedance MAPE per band", bb.impedance, "%"),
            ("bearing transfer rel. RMS error per band", bb.bearing, "")), strict=True):
        grey = _matrix(table, "grey", len(x))
        black = _matrix(table, "black", len(x))
        if grey.size:
            ax.bar(x - 0.2, _colmean(grey), 0.4, label="grey box")
            ax.bar(x + 0.2, _colmean(black), 0.4, label="black box (vector fit)")
        ax.set_xticks(x, centres, fontsize=7)
        ax.set_yscale("log")
        ax.set_title(title)
        ax.set_ylabel(unit)
        ax.legend(fontsize=7)
        ax.grid(True, axis="y", alpha=0.3)
    save(fig, out / "blackbox_errors.png")
    names.append("blackbox_errors.png")
    fig, axes = plt.subplots(1, 2, figsize=(11, 5))
    sets = [("impedance U-Frame", bb.models.get("impedance:U-Frame"),
             bb.network_poles_standstill)]
    rot = [k for k in bb.models if k.startswith("bearing:")]
    if rot:
        sets.append((f"bearing transfer {rot[-1].split(':')[1]} rpm", bb.models[rot[-1]],
                     bb.network_poles_rotating if bb.network_poles_rotating is not None
                     else bb.network_poles_standstill))
    for ax, (title, model, netp) in zip(axes, sets, strict=False):
        q = netp / (2 * np.pi)
        ax.plot(q.real, q.imag, "o", mfc="none", label=f"network poles ({netp.size})")
        if model is not None:
            p = model.poles / (2 * np.pi)
            ax.plot(p.real, p.imag, "x", label=f"vector-fit poles ({p.size})")
        ax.set_xscale("symlog", linthresh=1e3)
        ax.set_yscale("symlog", linthresh=1e3)
        ax.set_xlabel("Re p / 2pi (Hz)")
        ax.set_ylabel("Im p / 2pi (Hz)")
        ax.set_title(title)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    save(fig, out / "poles.png")
    names.append("poles.png")
    return names


def write_figures(res: ReproduceResult, out: Path) -> list[str]:
    """All figures into ``out``; returns their file names in report order. The figures
    are independent and drawn side by side in processes where
    :func:`vfmodel.report._mpl.draw_side_by_side` can (each writes its own files)."""
    rot = [s for s in res.speeds if s.speed_rpm > 0]
    jobs: list[partial[list[str]]] = [partial(_names, _impedance, res, out, g)
                                      for g in ("CM", "DM")]
    if res.speeds:
        jobs.append(partial(_names, _bvr_f, rot[-1] if rot else res.speeds[-1], out))
    jobs += [partial(_names, _bearing, s, out, False) for s in res.speeds]
    jobs.append(partial(_names, _lubricant, res, out))
    jobs += [partial(_names, _bearing, s, out, True)
             for s in (res.speeds[:2] if len(res.speeds) > 1 else res.speeds)]
    jobs.append(partial(_names, _blackbox, res, out))
    return draw_side_by_side(jobs)


def _names(fig: Callable[..., str | list[str] | None], *args: Any) -> list[str]:
    """The file names one figure function wrote (it returns one, a list or None)."""
    got = fig(*args)
    return [] if got is None else [got] if isinstance(got, str) else list(got)
