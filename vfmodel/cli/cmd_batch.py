"""``vfmodel batch fit FILES... --out DIR`` and ``vfmodel batch reproduce DATASETS... --out
DIR``: many jobs at once, locally (one process per core) or on a Dask cluster.

Each job is exactly the single command (``vfmodel fit FILE --out DIR/<name>``, the same code
path, so its outputs are those of a single run) written into its own sub-folder; a failed
job is reported and the others go on. DIR/batch_summary.csv and DIR/batch_summary.html
list every job's figures; the exit status is 0 when every job succeeded, 1 otherwise.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from vfmodel.cli._common import progress_bar, quiet_option
from vfmodel.greybox.effects import SECTIONS

__all__ = ["batch", "fit_job", "reproduce_job"]


def _run_cli(argv: list[str]) -> tuple[int, str]:
    """Run one vfmodel command as its own process, exactly as from a shell (own warnings,
    environment and output streams: jobs sharing a worker never mix); (exit status, first
    line of stderr that is not a warning)."""
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", "from vfmodel.cli._entry import entry; "
                           "entry()", *argv], capture_output=True, text=True, check=False)
    lines = [ln for ln in proc.stderr.splitlines()
             if ln.strip() and not ln.startswith("vfmodel: warning")]
    return proc.returncode, (lines[0] if lines else "")


def fit_job(spectrum: str, out_dir: str, extra: tuple[str, ...] = ()) -> dict[str, Any]:
    """``vfmodel fit SPECTRUM --out OUT_DIR EXTRA...``; the figures of its model.json."""
    code, msg = _run_cli(["fit", spectrum, "--out", out_dir, "--quiet", *extra])
    if code != 0:
        return {"error": msg or f"exit status {code}", "exit": code}
    doc = json.loads((Path(out_dir) / "model.json").read_text(encoding="utf-8"))
    return {"kind": doc.get("kind"), "ports": doc.get("n_out"), "order": len(doc["poles"]),
            "rel_rms_error": doc.get("rel_rms_error"),
            "point_rel_max_error": doc.get("point_rel_max_error"),
            "passive": doc.get("passive")}


def reproduce_job(dataset: str, out_dir: str, extra: tuple[str, ...] = ()) -> dict[str, Any]:
    """``vfmodel reproduce DATASET --out OUT_DIR EXTRA...``; its headline figures."""
    code, msg = _run_cli(["reproduce", dataset, "--out", out_dir, "--quiet", *extra])
    if code != 0:
        return {"error": msg or f"exit status {code}", "exit": code}
    r = json.loads((Path(out_dir) / "results.json").read_text(encoding="utf-8"))
    imp, bea = r.get("impedance", {}), r.get("bearing", {})
    return {"mean_mape_pct": imp.get("mean_mape_pct"),
            "mean_coherence": imp.get("mean_coherence"),
            "mean_rel_err_pct_rotating": bea.get("mean_rel_err_pct_rotating"),
            "mean_spectral_corr": bea.get("mean_spectral_corr"),
            "flagged_speeds": " ".join(r.get("flagged_speeds") or [])}


def job_names(paths: tuple[Path, ...]) -> list[str]:
    """A sub-folder name per input (its stem; ``_2``, ``_3`` ... for repeated stems)."""
    names: list[str] = []
    for p in paths:
        base = "".join(ch if ch.isalnum() or ch in "-_.," else "_" for ch in p.stem) or "job"
        name, k = base, 2
        while name in names:
            name, k = f"{base}_{k}", k + 1
        names.append(name)
    return names


def run(kind: str, inputs: tuple[Path, ...], out_dir: Path, extra: tuple[str, ...],
        workers: int | None, scheduler: str | None, quiet: bool, client: Any = None) -> int:
    """Run the batch, write the summaries; the exit status (0 all ok, 1 some failed)."""
    from vfmodel.core.atomic import check_output_place
    from vfmodel.pipeline.batch import Job, run_batch
    from vfmodel.report.batch_html import write_batch_summary

    check_output_place(out_dir, "--out", directory=True)
    out_dir.mkdir(parents=True, exist_ok=True)
    func = fit_job if kind == "fit" else reproduce_job
    names = job_names(inputs)
    jobs = [Job(n, func, (str(p), str(out_dir / n), extra))
            for n, p in zip(names, inputs, strict=True)]
    prog = progress_bar(quiet)
    results = run_batch(jobs, workers=workers, scheduler=scheduler, client=client,
                        progress=prog)
    write_batch_summary(out_dir, kind, [str(p) for p in inputs], results)
    failed = [r for r in results if not r.ok]
    click.echo(f"{len(results) - len(failed)} of {len(results)} {kind} jobs succeeded; "
               f"wrote {out_dir / 'batch_summary.csv'} and batch_summary.html")
    for r in failed:
        click.echo(f"vfmodel: batch: {r.name} failed: {r.error}", err=True)
    return 1 if failed else 0


def _exit(code: int) -> None:
    if code:  # exit status 1: "vfmodel: failed: ..." after the per-job messages
        from vfmodel.errors import VfmodelError

        raise VfmodelError("some jobs of the batch failed (see batch_summary.csv)")


_workers = click.option("--workers", type=click.IntRange(min=1), default=None,
                        help="Local processes (default: one per core).")
_scheduler = click.option("--scheduler", default=None, metavar="tcp://HOST:PORT",
                          help="Run on this Dask distributed scheduler instead "
                          "(pip install 'vfmodel[batch]').")
_out = click.option("--out", "out_dir", required=True,
                    type=click.Path(file_okay=False, path_type=Path),
                    help="Output directory: one sub-folder per job and the summaries.")


@click.group()
def batch() -> None:
    """Run many fit or reproduce jobs at once (locally in parallel or on Dask)."""


@batch.command("fit")
@click.argument("spectra", metavar="FILES...", nargs=-1, required=True,
                type=click.Path(path_type=Path))
@click.option("--order", default="auto", show_default=True, help="As for 'vfmodel fit'.")
@click.option("--passive", is_flag=True, help="As for 'vfmodel fit'.")
@_workers
@_scheduler
@_out
@quiet_option
def batch_fit(spectra: tuple[Path, ...], order: str, passive: bool, workers: int | None,
              scheduler: str | None, out_dir: Path, quiet: bool) -> None:
    """Vector-fit every FILE separately (as 'vfmodel fit FILE --out DIR/<name>')."""
    extra = ("--order", order, *(("--passive",) if passive else ()))
    code = run("fit", spectra, out_dir, extra, workers, scheduler, quiet)
    _exit(code)


@batch.command("reproduce")
@click.argument("datasets", metavar="DATASETS...", nargs=-1, required=True,
                type=click.Path(path_type=Path))
@click.option("--no-blackbox", is_flag=True, help="As for 'vfmodel reproduce'.")
@click.option("--max-nfev", default=40, show_default=True, type=click.IntRange(5, 1000),
              help="As for 'vfmodel reproduce'.")
@click.option("--sections", default=",".join(map(str, SECTIONS)), show_default=True,
              help="As for 'vfmodel reproduce'.")
@_workers
@_scheduler
@_out
@quiet_option
def batch_reproduce(datasets: tuple[Path, ...], no_blackbox: bool, max_nfev: int,
                    sections: str, workers: int | None, scheduler: str | None, out_dir: Path,
                    quiet: bool) -> None:
    """Run the paper's pipeline on every DATASET (as 'vfmodel reproduce DATASET --out
    DIR/<name>')."""
    extra = ("--max-nfev", str(max_nfev), "--sections", sections,
             *(("--no-blackbox",) if no_blackbox else ()))
    code = run("reproduce", datasets, out_dir, extra, workers, scheduler, quiet)
    _exit(code)
