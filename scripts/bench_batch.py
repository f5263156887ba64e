"""Batch speed-up: N Touchstone fits on 2 local workers against one by one.

    .venv/bin/python scripts/bench_batch.py [--workers 2] [FILES...]

Default files: every Touchstone file of data/touchstone and data/vfbench. Both runs go
through :func:`vfmodel.pipeline.batch.run_batch` with the jobs of ``vfmodel batch fit``
(workers=1: one after the other in this process's order; workers=N: N local processes);
prints wall times, the speed-up and whether every model.json is identical between the two.
Not a test: the figure depends on the machine and its load.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main() -> None:
    from vfmodel.cli.cmd_batch import fit_job, job_names
    from vfmodel.pipeline.batch import Job, run_batch

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="*", type=Path)
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args()
    files = a.files or sorted(p for d in ("touchstone", "vfbench")
                              for p in (ROOT / "data" / d).iterdir()
                              if p.suffix.lower().startswith(".s") and p.suffix[-1] in "pP")
    names = job_names(tuple(files))
    times = {}
    with tempfile.TemporaryDirectory() as tmp:
        for w in (1, a.workers):
            out = Path(tmp) / f"w{w}"
            jobs = [Job(n, fit_job, (str(p), str(out / n))) for n, p in zip(names, files,
                                                                            strict=True)]
            t0 = time.perf_counter()
            res = run_batch(jobs, workers=w)
            times[w] = time.perf_counter() - t0
            ok = sum(r.ok for r in res)
            print(f"workers={w}: {times[w]:.1f} s wall for {len(jobs)} jobs ({ok} ok); "
                  f"sum of job times {sum(r.seconds for r in res):.1f} s", flush=True)
        same = all((Path(tmp) / "w1" / n / "model.json").read_text()
                   == (Path(tmp) / f"w{a.workers}" / n / "model.json").read_text()
                   for n in names if (Path(tmp) / "w1" / n / "model.json").is_file())
    print(f"speed-up {times[1] / times[a.workers]:.2f}x on {a.workers} workers; "
          f"model.json identical: {same}")


if __name__ == "__main__":
    main()
