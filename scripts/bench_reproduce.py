#!/usr/bin/env python
"""Benchmark of ``vfmodel reproduce``: time of each stage and the acceptance numbers.

    .venv/bin/python scripts/bench_reproduce.py [DATASET] [--out DIR] [--ngspice]
        [--save FILE] [--baseline FILE]

Runs the reproduce pipeline (identification, validation, BVR baseline, black box) on
DATASET (default data/pmsm40kw), writes the outputs like the CLI, prints the wall time per
progress stage and the must-show numbers of issue 7 against their targets, and with
``--ngspice`` checks that ngspice's .ac of every exported netlist reproduces the modelled
impedances (max relative deviation).

``--save FILE`` writes the times and accuracy figures as JSON; ``--baseline FILE`` (a file
saved by an earlier version) prints them side by side with this run's, with the largest
relative change of the accuracy figures (issue 18: a speed-up keeps the figures).

Profile (issue 18; the output is not committed):

    OPENBLAS_NUM_THREADS=1 .venv/bin/python -m cProfile -o /tmp/repro.prof \
        scripts/bench_reproduce.py data/pmsm40kw
    .venv/bin/python -c "import pstats; pstats.Stats('/tmp/repro.prof')\
        .sort_stats('cumulative').print_stats(40)"

(or ``py-spy record -o repro.svg -- .venv/bin/python scripts/bench_reproduce.py``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vfmodel.greybox.effects import SECTIONS


def main(argv: list[str] | None = None) -> int:
    from vfmodel.core.allocator import keep_large_blocks

    keep_large_blocks()         # as the CLI does
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dataset", nargs="?", default="data/pmsm40kw")
    ap.add_argument("--out", default=None, help="output directory (default: a temp dir)")
    ap.add_argument("--sections", default=",".join(map(str, SECTIONS)))
    ap.add_argument("--ngspice", action="store_true")
    ap.add_argument("--save", default=None, help="write times and figures as JSON")
    ap.add_argument("--baseline", default=None,
                    help="JSON of an earlier --save: print its figures beside this run's")
    a = ap.parse_args(argv)

    from vfmodel.core.atomic import atomic_write_text, write_json
    from vfmodel.core.io_dataset import read_dataset
    from vfmodel.pipeline.reproduce import reproduce
    from vfmodel.report.html import write_reproduce_html
    from vfmodel.report.reproduce_figures import write_figures

    times: dict[str, float] = {}
    order: list[str] = []
    cur = [""]
    since = [time.perf_counter()]

    def progress(stage: str, done: int, total: int) -> None:
        now = time.perf_counter()
        if stage != cur[0]:
            if cur[0]:
                times[cur[0]] = times.get(cur[0], 0.0) + now - since[0]
            cur[0], since[0] = stage, now
            if stage not in order:
                order.append(stage)

    t0 = time.perf_counter()
    ds = read_dataset(a.dataset)
    t_read = time.perf_counter() - t0
    res = reproduce(ds, sections=tuple(int(s) for s in a.sections.split(",")),
                    progress=progress)
    progress("(end)", 0, 0)
    t_pipe = time.perf_counter() - t0
    out = Path(a.out) if a.out else Path(__import__("tempfile").mkdtemp(prefix="repro-"))
    out.mkdir(parents=True, exist_ok=True)
    t1 = time.perf_counter()
    for name, text in res.netlists.items():
        atomic_write_text(out / name, text)
    figs = write_figures(res, out)
    write_reproduce_html(out / "report.html", res.results, figs)
    write_json(out / "results.json", res.results)
    t_write = time.perf_counter() - t1
    print(f"dataset {a.dataset}: read {t_read:.1f} s")
    for s in order:
        if s in times:
            print(f"  {s:40s} {times[s]:7.1f} s")
    print(f"  {'figures, report, netlists':40s} {t_write:7.1f} s")
    print(f"total {t_pipe + t_write:.1f} s (target < 30 s on 2 cores, idle); outputs in {out}")
    r = res.results
    imp, bea = r["impedance"], r["bearing"]
    base = r["baseline_bvr"]
    print(f"winding sections selected: {r['model']['n_sections']}")
    print(f"impedance mean MAPE {imp['mean_mape_pct']:.3f} % (target <= 3), mean coherence "
          f"{imp['mean_coherence']:.5f} (target >= 0.995)")
    for k, v in bea.items():
        if isinstance(v, dict):
            print(f"  {k:>5} rpm: peak meas {v['peak_measured_v']:.3f} V model "
                  f"{v['peak_model_v']:.3f} V  abs {v['abs_err_v']:.3f} V rel "
                  f"{v['rel_err_pct']:.2f} %  corr {v['spectral_corr']:.4f}  resid rms "
                  f"{v['residual_rms_v']:.4f} V | BVR model "
                  f"{base[k]['peak_model_v']:.3f} V rel {base[k]['rel_err_pct']:.1f} %  "
                  f"film R {v['lubricant']['r_ohm']:.3g} ohm C {v['lubricant']['c_f']:.3g} F")
    print(f"mean rel peak error rotating {bea.get('mean_rel_err_pct_rotating', float('nan')):.2f} %"
          f" (target <= 5); abs error at 0 rpm "
          f"{bea.get('0', {}).get('abs_err_v', float('nan')):.3f} V (target <= 0.08); "
          f"mean spectral corr {bea['mean_spectral_corr']:.4f} (target >= 0.95)")
    print(f"grey box beats BVR at every speed: {all(r['greybox_beats_baseline'].values())}")
    truth_file = Path(a.dataset) / "truth.json"
    if truth_file.is_file():
        # virtual bench only: its noise-free peaks (never read by the pipeline)
        import json

        tr = json.loads(truth_file.read_text()).get("recordings", {})
        for k, v in bea.items():
            if isinstance(v, dict) and k in tr and "peak_u_b_clean_v" in tr[k]:
                c = tr[k]["peak_u_b_clean_v"]
                print(f"  diagnostic (bench truth.json, not used by the pipeline) {k:>4} rpm: "
                      f"noise-free peak {c:.3f} V, model {v['peak_model_v']:.3f} V "
                      f"({100 * (v['peak_model_v'] / c - 1):+.1f} %), measured "
                      f"{v['peak_measured_v']:.3f} V ({100 * (v['peak_measured_v'] / c - 1):+.1f} %"
                      f" from noise)")
    figs_now = figures(r, times, t_pipe + t_write, t_write)
    if a.save:
        import json

        Path(a.save).write_text(json.dumps(figs_now, indent=1))
    if a.baseline:
        compare(figs_now, a.baseline)
    if a.ngspice:
        from vfmodel.circuit.ngspice import run_ac
        from vfmodel.circuit.spice_import import from_spice
        from vfmodel.greybox.assembly import TOPOLOGY_PORTS

        worst = 0.0
        for text in res.netlists.values():
            circ = from_spice(text)
            for p, n in TOPOLOGY_PORTS.values():
                net = text.replace("\n.end", f"\nIZ {n} {p} DC 0 AC 1\n.end")
                probe = f"v({p})" if n == "0" else f"v({p},{n})"
                ac = run_ac(net, [probe], f_start_hz=1e3, f_stop_hz=1e7, points_per_decade=20)
                z = circ.port_impedance(ac.freq_hz, [(p, n)])[:, 0, 0]
                worst = max(worst, float(np.max(np.abs(ac.values[:, 0] - z) / np.abs(z))))
        print(f"ngspice .ac of {len(res.netlists)} netlists x 6 topologies: max rel. "
              f"deviation {worst:.2e} (target <= 1e-6)")
    return 0


def figures(r: dict[str, Any], times: dict[str, float], total_s: float,
            write_s: float) -> dict[str, dict[str, float]]:
    """Times (s) and accuracy figures of a run, flat, for --save / --baseline."""
    acc: dict[str, float] = {
        "n_sections": float(r["model"]["n_sections"]),
        "impedance mean MAPE %": r["impedance"]["mean_mape_pct"],
        "impedance mean coherence": r["impedance"]["mean_coherence"],
    }
    bea, base = r["bearing"], r["baseline_bvr"]
    for k, v in bea.items():
        if isinstance(v, dict):
            acc[f"{k} rpm peak model V"] = v["peak_model_v"]
            acc[f"{k} rpm rel err %"] = v["rel_err_pct"]
            acc[f"{k} rpm spectral corr"] = v["spectral_corr"]
            acc[f"{k} rpm resid rms V"] = v["residual_rms_v"]
            acc[f"{k} rpm film R ohm"] = v["lubricant"]["r_ohm"]
            acc[f"{k} rpm film C F"] = v["lubricant"]["c_f"]
            acc[f"{k} rpm BVR peak V"] = base[k]["peak_model_v"]
    acc["mean rel err rotating %"] = bea.get("mean_rel_err_pct_rotating", float("nan"))
    acc["mean spectral corr"] = bea["mean_spectral_corr"]
    tm = {"total": total_s, "figures, report, netlists": write_s, **times}
    return {"times_s": tm, "figures": {k: float(v) for k, v in acc.items()}}


def compare(now: dict[str, dict[str, float]], baseline: str) -> None:
    """Print this run's times and figures beside those of ``baseline`` (JSON of --save)."""
    import json

    old = json.loads(Path(baseline).read_text())
    print(f"\n{'':40s} {'this run':>12s} {'baseline':>12s}")
    for k in ("total", *sorted(set(now["times_s"]) - {"total"})):
        a, b = now["times_s"].get(k), old["times_s"].get(k)
        print(f"  {k:38s} {_fmt(a):>12s} {_fmt(b):>12s}  s")
    worst = 0.0
    for k, a in now["figures"].items():
        b = old["figures"].get(k)
        rel = abs(a - b) / max(abs(b), 1e-300) if b is not None else float("nan")
        worst = max(worst, rel) if np.isfinite(rel) else worst
        print(f"  {k:38s} {a:12.6g} {_fmt(b, '.6g'):>12s}  rel. change {rel:.1e}")
    print(f"largest relative change of the accuracy figures: {worst:.1e}")


def _fmt(x: float | None, spec: str = ".1f") -> str:
    return "-" if x is None else format(x, spec)


if __name__ == "__main__":
    sys.exit(main())
