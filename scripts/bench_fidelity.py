#!/usr/bin/env python
"""Grey-box fidelity on benches the model was not built from (issue 19).

    .venv/bin/python scripts/bench_fidelity.py [--seeds 101,102,103,104,105]
        [--dir /tmp/fidelity] [--jobs 2] [--dataset data/pmsm40kw ...]

For every seed an independent bench (benches/independent.py: two bearings with inner and
outer race contacts, conducting thickener layer growing with speed, three-section cable,
PWM duty jitter, per-channel probes, EMI 14-37 MHz, metallic contact at standstill; drawn
values) is written under ``--dir`` unless it exists, ``reproduce`` runs on it (no black
box), and one table prints, per bench and speed, the paper's metrics: impedance MAPE and
coherence, peak bearing-voltage error (0 rpm absolute, rotating relative), spectral
correlation, the plateau error (bearing voltage below 200 kHz), the classical BVR model's
peak and plateau errors, whether the grey box beats it, and whether the 95 % intervals of
the bearing (divider) capacitance, of the winding-rotor capacitance and of the common-mode
bearing transfer at 100 kHz (``H_cm``: bearing voltage per volt of common mode, the
plateau level; benches.independent.cm_transfer) cover the truth (an interval wider than
``MAX_WIDTH`` = 100x says the data do not fix the value: it is printed as None and not
counted; the summary gives the widths per quantity). With the metallic contact the
capacitances' scale is known only through its physics prior (vfmodel.greybox.path_prior),
while ``H_cm`` is what the records fix. Intervals that carry a structural model-error term
(``std_log_noise`` and ``model_error_log`` in results.json, vfmodel.greybox.model_error) are
also counted without it (the noise-only interval ``value exp(+-1.96 std_log_noise)``).
The same settings for every bench (no per-bench tuning). ``--dataset`` adds datasets
without a known truth (e.g. data/pmsm40kw): metrics only.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any, get_args

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vfmodel._choices import SectionsBy
from vfmodel.greybox.effects import JOINT_REFIT, LUBRICANT_MAX_NFEV, LUBRICANT_RANDOM_STARTS

GOALS = {"rot_mean": 5.0, "rot_max": 8.0, "abs0": 0.08, "corr": 0.95, "mape": 3.0,
         "coherence": 0.995, "coverage": 0.90}


def _run(path: str, seed: int | None, rotating_fit: str = "record",
         standstill_fit: str = "combined", extra_effects: tuple[str, ...] = (),
         max_nfev: int = 40, max_nfev_lubricant: int = LUBRICANT_MAX_NFEV,
         random_starts: int = LUBRICANT_RANDOM_STARTS,
         joint: bool = JOINT_REFIT, sections_by: str = "spectra") -> dict[str, Any]:
    """Reproduce one dataset (the paper's network plus ``extra_effects``); returns its
    metrics and the truth comparison."""
    from vfmodel.core.io_dataset import read_dataset
    from vfmodel.greybox.effects import PAPER_EFFECTS
    from vfmodel.pipeline.reproduce import reproduce

    t0 = time.perf_counter()
    res = reproduce(read_dataset(path), blackbox=False,
                    effects=tuple(sorted(PAPER_EFFECTS | set(extra_effects))),
                    rotating_fit=rotating_fit,  # type: ignore[arg-type]
                    standstill_fit=standstill_fit,  # type: ignore[arg-type]
                    max_nfev=max_nfev, max_nfev_lubricant=max_nfev_lubricant,
                    lubricant_random_starts=random_starts, joint=joint,
                    sections_by=sections_by).results  # type: ignore[arg-type]
    out: dict[str, Any] = {"path": path, "seed": seed, "seconds": time.perf_counter() - t0,
                           "results": res, "covers": {}}
    if seed is not None:
        from benches.independent import draw, equivalents

        d = draw(seed)
        covers: dict[str, bool | None] = {}
        film_cov: dict[str, bool | None] = {}
        iv = res["model"].get("divider_intervals", {}).get("c_wr_f")
        truth0 = equivalents(d, 0.0)
        widths: dict[str, float] = {}
        noise: dict[str, tuple[bool | None, float]] = {}  # the intervals without model error

        def count(name: str, iv: dict[str, Any], truth: float) -> None:
            covers[name], widths[name] = _cover(iv, truth)
            if iv.get("std_log_noise") is not None:
                noise[name] = _cover(_noise_only(iv), truth)

        if iv and iv["lo"] is not None:
            count("c_wr", iv, truth0["c_wr_lf_f"])
        for k, v in res["bearing"].items():
            if not isinstance(v, dict) or "lubricant_interval" not in v:
                continue
            tr = equivalents(d, float(k))
            ib = v["lubricant_interval"]["c_b_100khz_f"]
            if ib["lo"] is not None:
                count(f"c_b@{k}", ib, tr["c_b_100khz_f"])
            out.setdefault("truth", {})[k] = {"c_b_100khz_f": tr["c_b_100khz_f"], "model": ib}
            # the plateau level (bearing voltage per volt of common mode at 100 kHz): what
            # the records fix when the divider's scale is known only through its prior
            ih = v["lubricant_interval"].get("cm_transfer_100khz")
            if ih is not None and ih["lo"] is not None:
                count(f"h_cm@{k}", ih, tr["cm_transfer_100khz"])
                out["truth"][k].update(cm_transfer_100khz=tr["cm_transfer_100khz"],
                                       model_cm=ih)
            # the film itself: DC resistance and high-frequency capacitance (reported, not
            # part of the goal: an interval wider than 100x says the data do not fix it)
            for key, tk in (("r_ohm", "film_r_ohm"), ("c_f", "film_c_f")):
                fi = v["lubricant_interval"][key]
                if fi.get("bound") == "lower":  # a one-sided bound: counted apart
                    # (held, informative: within MAX_WIDTH of the value)
                    out.setdefault("film_lower", {})[f"{key}@{k}"] = (
                        None if fi["lo"] is None else bool(fi["lo"] <= tr[tk]),
                        fi["lo"] is not None and fi["value"] <= MAX_WIDTH * fi["lo"])
                    continue
                film_cov[f"{key}@{k}"] = _cover(fi, tr[tk])[0]
        out["covers"] = covers
        out["widths"] = widths
        out["noise_only"] = noise
        out["covers_film"] = film_cov
        # spectral correlation a perfect model reaches against the noisy record
        tj = Path(path) / "truth.json"
        if tj.is_file():
            recs = json.loads(tj.read_text()).get("recordings", {})
            out["corr_ceiling"] = {k: v.get("spectral_corr_ceiling") for k, v in recs.items()}
            out["pcorr_ceiling"] = {k: v.get("spectral_corr_periodogram_ceiling")
                                    for k, v in recs.items()}
            # the noise-free bearing voltage's peak: the measured one is its maximum
            # plus noise (at standstill's ~1 dB SNR a bias of a few 10 mV)
            out["peak_clean_v"] = {k: v.get("peak_u_b_clean_v") for k, v in recs.items()}
    return out


def _table(runs: list[dict[str, Any]]) -> list[str]:
    def pct(x: float | None, w: int) -> str:
        return f"{'null':>{w}}" if x is None else f"{x:{w}.2f}%"

    lines = [f"{'bench':<14}{'rpm':>5} {'peak err':>10} {'corr':>7} {'(ceil)':>7} "
             f"{'pgram':>7} {'(ceil)':>7} {'plateau':>8} "
             f"{'BVR peak':>9} {'BVR plat':>9} {'beats':>6} {'95% covers C_b/H_cm':>20}"]
    for r in runs:
        res = r["results"]
        name = Path(r["path"]).name
        imp = res["impedance"]
        lines.append(f"{name:<14} impedance MAPE {imp['mean_mape_pct']:.2f} %, coherence "
                     f"{imp['mean_coherence']:.5f}; {r['seconds']:.0f} s; covers "
                     f"C_wr: {r['covers'].get('c_wr')}")
        for k, v in res["bearing"].items():
            if not isinstance(v, dict):
                continue
            b = res["baseline_bvr"][k]
            err = (f"{v['abs_err_v']:.3f} V" if v["state"] == "standstill"
                   else pct(v["rel_err_pct"], 8))
            ceil = r.get("corr_ceiling", {}).get(k)
            ceil_s = f"{ceil:7.4f}" if ceil is not None else f"{'-':>7}"
            pceil = r.get("pcorr_ceiling", {}).get(k)
            pg = v.get("spectral_corr_periodogram")
            ceil_s += (f" {pg:7.4f}" if pg is not None else f" {'-':>7}") + (
                f" {pceil:7.4f}" if pceil is not None else f" {'-':>7}")
            beats = res["greybox_beats_baseline"][k]
            cov = f"{r['covers'].get(f'c_b@{k}', '-')}/{r['covers'].get(f'h_cm@{k}', '-')}"
            lines.append(f"{'':<14}{k:>5} {err:>10} {v['spectral_corr']:7.4f} {ceil_s} "
                         f"{pct(v['plateau_rel_err_pct'], 7)} {pct(b['rel_err_pct'], 8)} "
                         f"{pct(b['plateau_rel_err_pct'], 8)} {('yes' if beats else 'NO'):>6} "
                         f"{cov:>20}")
    return lines


def _summary(runs: list[dict[str, Any]]) -> list[str]:
    rot: list[float] = []
    abs0: list[float] = []
    corr, mape, coh, beats, cov = [], [], [], [], []
    corr_ceil: list[tuple[float, float]] = []
    pcorr: list[float] = []
    for r in runs:
        res = r["results"]
        mape.append(res["impedance"]["mean_mape_pct"])
        coh.append(res["impedance"]["mean_coherence"])
        for k, v in res["bearing"].items():
            if not isinstance(v, dict):
                continue
            corr.append(v["spectral_corr"])
            if v.get("spectral_corr_periodogram") is not None:
                pcorr.append(v["spectral_corr_periodogram"])
            val = v["abs_err_v"] if v["state"] == "standstill" else v["rel_err_pct"]
            # an undefined error (null) counts as the worst
            (abs0 if v["state"] == "standstill" else rot).append(
                float("inf") if val is None else val)
            ceil = r.get("corr_ceiling", {}).get(k)
            if ceil is not None:
                corr_ceil.append((v["spectral_corr"], ceil))
            beats.append(res["greybox_beats_baseline"][k])
        cov += [c for c in r["covers"].values() if c is not None]
    out = []

    def line(label: str, value: str, ok: bool) -> None:
        out.append(f"  {label:<48} {value:<22} {'PASS' if ok else 'FAIL'}")

    if rot:
        mean_rot = sum(rot) / len(rot)
        line("rotating peak error, mean (<= 5 %)", f"{mean_rot:.2f} %",
             mean_rot <= GOALS["rot_mean"])
        line("rotating peak error, worst speed (<= 8 %)", f"{max(rot):.2f} %",
             max(rot) <= GOALS["rot_max"])
    if abs0:
        line("0 rpm absolute peak error, worst (<= 0.08 V)", f"{max(abs0):.3f} V",
             max(abs0) <= GOALS["abs0"])
        clean0 = [abs(v["peak_model_v"] - r["peak_clean_v"][k]) for r in runs
                  for k, v in r["results"]["bearing"].items()
                  if isinstance(v, dict) and v["state"] == "standstill"
                  and r.get("peak_clean_v", {}).get(k) is not None]
        if clean0:
            out.append(f"  {'(against the noise-free peak: mean, worst)':<48} "
                       f"{sum(clean0) / len(clean0):.3f} V, {max(clean0):.3f} V")
    line("spectral correlation, worst speed (>= 0.95)", f"{min(corr):.4f}",
         min(corr) >= GOALS["corr"])
    if corr_ceil:
        worst = min(corr_ceil, key=lambda t: t[0] - t[1])
        out.append(f"  {'(worst shortfall below the noise ceiling)':<48} "
                   f"{worst[0]:.4f} vs {worst[1]:.4f}")
    if pcorr:
        out.append(f"  {'(periodogram |FFT| correlation, worst speed)':<48} {min(pcorr):.4f}")
    line("grey box beats BVR at every speed", f"{sum(beats)}/{len(beats)}", all(beats))
    line("impedance MAPE, worst bench (<= 3 %)", f"{max(mape):.2f} %", max(mape) <= GOALS["mape"])
    line("impedance coherence, worst bench (>= 0.995)", f"{min(coh):.5f}",
         min(coh) >= GOALS["coherence"])
    for key, label in (("r_ohm", "film R (DC)"), ("c_f", "film C (high frequency)")):
        got = [c for r in runs for n, c in r.get("covers_film", {}).items()
               if n.startswith(key)]
        fixed = [c for c in got if c is not None]
        if got:
            out.append(f"  {f'({label} intervals: within {MAX_WIDTH:g}x / covering)':<48} "
                       f"{len(fixed)} of {len(got)} / {sum(fixed)} of {len(fixed)}")
    low = [c for r in runs for c in r.get("film_lower", {}).values()]
    if low:
        held = [c for c, _ in low if c is not None]
        near = [c for c, inf in low if inf]
        out.append(f"  {'(film R (DC) lower bounds only: below the truth)':<48} "
                   f"{sum(held)} of {len(held)} ({len(low) - len(held)} without a bound; "
                   f"within {MAX_WIDTH:g}x of the value: {sum(near)} of {len(near)} below)")
    for fam, label in (("c_wr", "C_wr"), ("c_b@", "C_b (100 kHz)"),
                       ("h_cm@", "H_cm (100 kHz)")):
        widths = sorted(w for r in runs for n, w in r.get("widths", {}).items()
                        if n.startswith(fam))
        if not widths:
            continue
        got = [c for r in runs for n, c in r["covers"].items() if n.startswith(fam)]
        fixed = [c for c in got if c is not None]
        out.append(f"  {f'({label} intervals: width hi/lo median, max)':<48} "
                   f"{widths[len(widths) // 2]:.3g}, {widths[-1]:.3g}; "
                   f"{len(got) - len(fixed)} of {len(got)} wider than {MAX_WIDTH:g}x (not "
                   f"counted), {sum(fixed)} of {len(fixed)} covering")
        nz = [v for r in runs for n, v in r.get("noise_only", {}).items() if n.startswith(fam)]
        if nz:
            nw = sorted(float(w) for _, w in nz)
            nf = [c for c, _ in nz if c is not None]
            out.append(f"  {f'({label} without the model-error term)':<48} "
                       f"{nw[len(nw) // 2]:.3g}, {nw[-1]:.3g}; {sum(nf)} of {len(nf)} covering")
    if cov:
        frac = sum(cov) / len(cov)
        line(f"95 % intervals (<= {MAX_WIDTH:g}x) covering the truth (>= 90 %)",
             f"{sum(cov)}/{len(cov)} ({100 * frac:.0f} %)", frac >= GOALS["coverage"])
    # the film's own values within 100x are intervals of the same kind: shown pooled too
    # (they extrapolate the film below the records' band, which is why the goal leaves
    # them out; docs/notes.md, session 26)
    film = [c for r in runs for c in r.get("covers_film", {}).values() if c is not None]
    if cov and film:
        both = cov + film
        out.append(f"  {'(the same with the film R/C intervals <= 100x)':<48} "
                   f"{sum(both)}/{len(both)} ({100 * sum(both) / len(both):.0f} %)")
    nz = [c for r in runs for c, _ in r.get("noise_only", {}).values() if c is not None]
    if nz:
        out.append(f"  {'(the same without the model-error term)':<48} "
                   f"{sum(nz)}/{len(nz)} ({100 * sum(nz) / len(nz):.0f} %)")
    return out


MAX_WIDTH = 100.0
"""An interval wider than this (hi/lo) says the data do not fix the value: it is reported
but not counted as covering (the goal is about identifiable parameters)."""


def _noise_only(iv: dict[str, Any]) -> dict[str, Any]:
    """The interval without its model-error term: ``value exp(+-1.96 std_log_noise)``."""
    half = 1.959964 * iv["std_log_noise"]
    return {"lo": iv["value"] * math.exp(-half), "hi": iv["value"] * math.exp(half)}


def _cover(iv: dict[str, Any], truth: float) -> tuple[bool | None, float]:
    """Whether the interval covers ``truth`` (None when wider than ``MAX_WIDTH``), and its
    width hi/lo (inf when unbounded below)."""
    lo, hi = iv["lo"], iv["hi"]
    width = hi / lo if lo and lo > 0 and hi is not None else float("inf")
    return (bool(lo <= truth <= hi) if width <= MAX_WIDTH else None), width


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="101,102,103,104,105")
    ap.add_argument("--dir", default="/tmp/fidelity", help="where the benches are written")
    ap.add_argument("--jobs", type=int, default=2, help="benches run side by side")
    ap.add_argument("--dataset", action="append", default=[],
                    help="extra dataset without known truth (repeatable)")
    ap.add_argument("--json", default=None, help="write every result to this file")
    ap.add_argument("--rotating-fit", default="record", choices=["record", "h1"],
                    help="condition 2 at speed: waveform over the whole band (default) or "
                         "the H1 transfer (the previous method, for comparison)")
    ap.add_argument("--standstill-fit", default="combined",
                    choices=["combined", "record", "h1"],
                    help="condition 2 at standstill: H1 and the waveform below 1 MHz "
                         "(default), the waveform or the H1 transfer alone (the method "
                         "before 2026-11-24), for comparison")
    ap.add_argument("--effects", default="",
                    help="effects added to the paper's network, comma-separated (e.g. "
                         "endwinding_capacitance, what the detective finds on these benches)")
    ap.add_argument("--max-nfev", type=int, default=40,
                    help="evaluation limit of the identification's stages (reproduce's "
                         "--max-nfev)")
    ap.add_argument("--max-nfev-lubricant", type=int, default=LUBRICANT_MAX_NFEV,
                    help="evaluation limit of each lubricant stage's starts (reproduce's "
                         "--max-nfev-lubricant)")
    ap.add_argument("--lubricant-random-starts", type=int, default=LUBRICANT_RANDOM_STARTS,
                    help="random starts added to each lubricant stage (reproduce's "
                         "--lubricant-random-starts)")
    ap.add_argument("--joint", action=argparse.BooleanOptionalAction, default=JOINT_REFIT,
                    help="joint refit of the rotor-side machine with every rotating record "
                         "(reproduce's default: %(default)s)")
    ap.add_argument("--sections-by", default="spectra", choices=get_args(SectionsBy),
                    help="how the winding-section count is chosen (reproduce's "
                         "--sections-by)")
    ap.add_argument("--random-start", action="store_true",
                    help="benches whose records start at a random point of a PWM period "
                         "(written as bench<seed>rs)")
    a = ap.parse_args(argv)
    from benches.independent import write_bench
    from vfmodel.errors import InputError
    from vfmodel.greybox.effects import check_effects

    extra = tuple(e for e in a.effects.split(",") if e)
    try:  # refused before any bench is written or fitted
        check_effects(extra, "--effects")
    except InputError as err:
        ap.error(str(err))

    jobs: list[tuple[str, int | None]] = []
    for s in (int(x) for x in a.seeds.split(",") if x):
        path = Path(a.dir) / f"bench{s}{'rs' if a.random_start else ''}"
        if not (path / "dataset.toml").exists():
            path.parent.mkdir(parents=True, exist_ok=True)
            t0 = time.perf_counter()
            write_bench(path, s, random_start=a.random_start)
            print(f"wrote {path} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
        jobs.append((str(path), s))
    jobs += [(d, None) for d in a.dataset]
    t0 = time.perf_counter()
    done: dict[int, dict[str, Any]] = {}
    with ProcessPoolExecutor(max_workers=max(1, a.jobs)) as ex:
        futs = {ex.submit(_run, p, s, a.rotating_fit, a.standstill_fit, extra,
                          a.max_nfev, a.max_nfev_lubricant, a.lubricant_random_starts,
                          a.joint, a.sections_by): k
                for k, (p, s) in enumerate(jobs)}
        for fut in as_completed(futs):
            r = done[futs[fut]] = fut.result()
            rot = r["results"]["bearing"].get("mean_rel_err_pct_rotating", float("nan"))
            print(f"[{len(done)}/{len(jobs)}] {Path(r['path']).name}: {r['seconds']:.0f} s, "
                  f"mean rotating peak error {rot:.2f} %",
                  file=sys.stderr, flush=True)
    runs = [done[k] for k in range(len(jobs))]
    print("\n".join(_table(runs)))
    truth_runs = [r for r in runs if r["seed"] is not None]
    if truth_runs:
        print(f"\nacceptance on {len(truth_runs)} independent benches "
              f"(wall {time.perf_counter() - t0:.0f} s):")
        print("\n".join(_summary(truth_runs)))
    if a.json:
        Path(a.json).write_text(json.dumps(runs, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
