"""Run many independent jobs: local processes (one per core) or a Dask distributed cluster.

A job is a picklable function and its arguments returning a dict of figures; a job that
raises is recorded as failed (its message kept) and the others go on. Results come back in
the order the jobs were given; ``progress("batch", done, total)`` is called as they finish.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Any

from vfmodel.core.progress import Progress, no_progress

__all__ = ["Job", "JobResult", "run_batch"]


@dataclass(frozen=True)
class Job:
    """``func(*args)`` under the name ``name`` (unique in a batch)."""

    name: str
    func: Callable[..., dict[str, Any]]
    args: tuple[Any, ...] = ()


@dataclass(frozen=True)
class JobResult:
    """What one job gave: its figures, or the error that stopped it."""

    name: str
    ok: bool
    seconds: float
    figures: dict[str, Any] = field(default_factory=dict)
    error: str | None = None


def _timed(func: Callable[..., dict[str, Any]], args: tuple[Any, ...]) -> tuple[bool, float,
                                                                             Any]:
    """Run a job in the worker; an exception becomes (False, seconds, message)."""
    t0 = time.perf_counter()
    try:
        out = func(*args)
    except Exception as ex:  # a failed job must not stop the batch
        return False, time.perf_counter() - t0, f"{type(ex).__name__}: {ex}"
    return True, time.perf_counter() - t0, out


def _result(job: Job, triple: tuple[bool, float, Any]) -> JobResult:
    ok, sec, out = triple
    if ok and isinstance(out, dict) and out.get("error"):
        return JobResult(job.name, False, sec, {k: v for k, v in out.items() if k != "error"},
                         str(out["error"]))
    if ok:
        return JobResult(job.name, True, sec, dict(out))
    return JobResult(job.name, False, sec, {}, str(out))


def run_batch(jobs: Sequence[Job], *, workers: int | None = None, scheduler: str | None = None,
              client: Any = None, progress: Progress = no_progress) -> list[JobResult]:
    """Run ``jobs`` in parallel and return their results in order.

    Without ``scheduler``/``client``: a local pool of ``workers`` processes (default: one
    per core; 1 runs them one by one in this process). With ``scheduler``
    (``tcp://HOST:PORT``) or a ``distributed.Client`` ``client``: on that Dask cluster
    (``pip install vfmodel[batch]``).
    """
    n = len(jobs)
    results: list[JobResult | None] = [None] * n
    progress("batch", 0, n)
    if client is not None or scheduler is not None:
        return _dask(jobs, scheduler, client, progress)
    workers = workers or os.cpu_count() or 1
    if workers <= 1 or n <= 1:
        for i, j in enumerate(jobs):
            results[i] = _result(j, _timed(j.func, j.args))
            progress("batch", i + 1, n)
        return [r for r in results if r is not None]
    with ProcessPoolExecutor(max_workers=min(workers, n)) as pool:
        futs: dict[Future[Any], int] = {pool.submit(_timed, j.func, j.args): i
                                        for i, j in enumerate(jobs)}
        pending = set(futs)
        done_n = 0
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for f in done:
                i = futs[f]
                try:
                    results[i] = _result(jobs[i], f.result())
                except Exception as ex:  # a worker that died (memory, signal)
                    results[i] = JobResult(jobs[i].name, False, 0.0, {},
                                           f"{type(ex).__name__}: {ex}")
                done_n += 1
                progress("batch", done_n, n)
    return [r for r in results if r is not None]


def _dask(jobs: Sequence[Job], scheduler: str | None, client: Any,
          progress: Progress) -> list[JobResult]:
    try:
        from distributed import Client, as_completed
    except ImportError:  # pragma: no cover - depends on the installation
        from vfmodel.errors import InputError

        raise InputError("a Dask scheduler needs the 'distributed' package", place="--scheduler",
                         expected="pip install 'vfmodel[batch]'") from None
    own = client is None
    if own:
        client = Client(scheduler, timeout=30)
    try:
        futs = [client.submit(_timed, j.func, j.args, key=f"vfmodel-batch-{i}-{j.name}",
                              pure=False) for i, j in enumerate(jobs)]
        index = {f.key: i for i, f in enumerate(futs)}
        results: list[JobResult | None] = [None] * len(jobs)
        for k, f in enumerate(as_completed(futs), start=1):
            i = index[f.key]
            try:
                results[i] = _result(jobs[i], f.result())
            except Exception as ex:  # a lost worker
                results[i] = JobResult(jobs[i].name, False, 0.0, {},
                                       f"{type(ex).__name__}: {ex}")
            progress("batch", k, len(jobs))
        return [r for r in results if r is not None]
    finally:
        if own:
            client.close()
