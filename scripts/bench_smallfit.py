"""Small fits: vfmodel's ``vector_fit(net)`` against scikit-rf's ``auto_fit`` on every 1-2
port Touchstone file of at most 2,000 points that scikit-rf ships and that data/vfbench
holds, both timed in this process, interleaved, median over ``--runs``.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python scripts/bench_smallfit.py [--runs 7] [--files GLOB]
                                                  [--extra DIR ...] [--only-extra]

Per file: points, ports, median fit time of each tool, ratio vfmodel / scikit-rf, each
tool's automatic order (every pole counted) and relative RMS error
``||S_model - S_data||_F / ||S_data||_F``; then the median of the per-file ratios and
the median of each tool's times over the same files (the two readings of "median fit
time": the ratios say how often vfmodel is the faster one, the times how long a typical
small file takes with each).
``--agilent`` adds the Agilent 4-port (data/touchstone), timed the same way; ``--extra DIR``
adds the Touchstone files of DIR (files never seen), ``--only-extra`` times those alone. A
file whose first scikit-rf fit runs beyond ``--skrf-limit`` seconds (60) is shown, not timed
(NanoVNA-Saver's sucoflex290mm.s1p: more than 10 minutes).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
import warnings
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
_SMALL = (2, 2000)  # ports, points


def _files(pattern: str | None, agilent: bool, extra: list[str], only_extra: bool
           ) -> list[Path]:
    from vfbench import _files as vfbench_files  # the files vfbench runs (scripts/ on path)

    out = vfbench_files(extra, pattern)
    if only_extra:
        own = set(vfbench_files([], pattern))
        out = [p for p in out if p not in own]
    if agilent:
        out.append(ROOT / "data" / "touchstone" / "Agilent_E5071B.s4p")
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", type=int, default=7)
    p.add_argument("--files", default=None, help="only files whose name matches this glob")
    p.add_argument("--agilent", action="store_true", help="add the Agilent 4-port")
    p.add_argument("--extra", action="append", default=[], help="more Touchstone folders")
    p.add_argument("--only-extra", action="store_true", help="time the --extra files alone")
    p.add_argument("--skrf-limit", type=float, default=60.0,
                   help="seconds after which scikit-rf's first fit of a file is stopped")
    args = p.parse_args()
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    import numpy as np
    import skrf

    sys.path.insert(0, str(ROOT))
    sys.path.insert(0, str(ROOT / "scripts"))
    from vfbench import time_limit

    from benches.skrf_reference import skrf_order, skrf_response
    from vfmodel.fitting.vectfit import vector_fit

    warnings.simplefilter("ignore")
    print(f"{'file':<34} {'pts':>5} {'ports':>5} {'vf s':>8} {'skrf s':>8} {'ratio':>6} "
          f"{'N vf':>5} {'N skrf':>6} {'err vf':>9} {'err skrf':>9}")
    medians: list[tuple[float, float]] = []  # each small file's median times: vfmodel, scikit-rf
    for path in _files(args.files, args.agilent, args.extra, args.only_extra):
        net = skrf.Network(str(path))
        k, n = net.s.shape[0], net.s.shape[1]
        big = path.name.startswith("Agilent")
        if not big and (n > _SMALL[0] or k > _SMALL[1]):
            continue
        t_vf: list[float] = []
        t_sk: list[float] = []
        out_vf: Any = None
        out_sk: Any = None
        try:
            vector_fit(net)  # warm (imports, caches) for both tools alike
            with time_limit(args.skrf_limit, "scikit-rf's auto_fit"):  # can run for ever
                skrf.vectorFitting.VectorFitting(net).auto_fit()
            for _ in range(args.runs):
                t0 = time.perf_counter()
                out_vf = vector_fit(net)
                t_vf.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                out_sk = skrf.vectorFitting.VectorFitting(net)
                out_sk.auto_fit()
                t_sk.append(time.perf_counter() - t0)
        except Exception as err:  # a tool refusing the file: shown, not timed
            print(f"{path.name:<34} {k:5d} {n:5d}  {type(err).__name__}: {str(err)[:60]}",
                  flush=True)
            continue
        f, h = net.f, net.s
        model, _ = out_vf
        err_vf = float(np.linalg.norm(model(f) - h) / np.linalg.norm(h))
        h_sk = skrf_response(out_sk, f)
        err_sk = float(np.linalg.norm(h_sk - h) / np.linalg.norm(h))
        n_sk = skrf_order(out_sk)
        tv, ts = statistics.median(t_vf), statistics.median(t_sk)
        if not big:
            medians.append((tv, ts))
        print(f"{path.name:<34} {k:5d} {n:5d} {tv:8.4f} {ts:8.4f} {tv / ts:6.2f} "
              f"{model.n_poles:5d} {n_sk:6d} {err_vf:9.2e} {err_sk:9.2e}", flush=True)
    if medians:
        ratio = statistics.median(v / s for v, s in medians)
        print(f"median time ratio vfmodel / scikit-rf over {len(medians)} small files: "
              f"{ratio:.3f}")
        mv = statistics.median(m[0] for m in medians)
        ms = statistics.median(m[1] for m in medians)
        print(f"median time over the same files: vfmodel {1e3 * mv:.1f} ms, scikit-rf "
              f"{1e3 * ms:.1f} ms (ratio {mv / ms:.2f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
