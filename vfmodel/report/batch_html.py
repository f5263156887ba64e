"""Summary of a batch: ``batch_summary.csv`` and a self-contained ``batch_summary.html``."""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from vfmodel.core.atomic import atomic_write_text
from vfmodel.report.page import Check, E, html_page, num, summary, table

__all__ = ["write_batch_summary"]

_UNITS = {"mean_mape_pct": "%", "mean_rel_err_pct_rotating": "%"}


def _columns(results: Sequence[Any]) -> list[str]:
    cols: list[str] = []
    for r in results:
        for k in r.figures:
            if k not in cols and k != "exit":
                cols.append(k)
    return cols


def write_batch_summary(out_dir: Path, kind: str, inputs: Sequence[str],
                        results: Sequence[Any]) -> None:
    """Write both summaries of ``results`` (:class:`vfmodel.pipeline.batch.JobResult`)."""
    cols = _columns(results)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["job", "input", "status", "seconds", *cols, "error"])
    for r, src in zip(results, inputs, strict=True):
        w.writerow([r.name, src, "ok" if r.ok else "FAILED", f"{r.seconds:.3f}",
                    *("" if r.figures.get(c) is None else r.figures.get(c) for c in cols),
                    r.error or ""])
    atomic_write_text(out_dir / "batch_summary.csv", buf.getvalue())
    failed = [r for r in results if not r.ok]
    rows = []
    for r, src in zip(results, inputs, strict=True):
        link = (f"<a href='{E(r.name)}/report.html'>{E(r.name)}</a>" if r.ok else E(r.name))
        cells = [num(v, _UNITS.get(c, "")) if isinstance(v, int | float) and
                 not isinstance(v, bool) else E("–" if v is None else str(v))
                 for c in cols for v in (r.figures.get(c),)]
        rows.append((link, E(src), "<span class='pass'>ok</span>" if r.ok else
                     "<span class='fail'>FAILED</span>", num(r.seconds, "s", digits=3), *cells,
                     f"<span class='text'>{E(r.error or '')}</span>"))
    checks = [Check("jobs that succeeded", f"{len(results) - len(failed)} of {len(results)}",
                    "–", "all", not failed)]
    look = [f"<b>{E(r.name)}</b> failed: {E(r.error or '')}" for r in failed]
    head = summary(f"vfmodel batch {kind}: {len(results)} jobs", "one sub-folder per job; "
                   "batch_summary.csv holds the same table", checks, look, "")
    body = [head, "<h2>Jobs</h2>",
            table(["job", "input", "status", "time", *map(E, cols), "error"], rows)]
    atomic_write_text(out_dir / "batch_summary.html", html_page(f"vfmodel batch {kind}", body))
