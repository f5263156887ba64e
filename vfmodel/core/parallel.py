"""Independent fits side by side: ``parallel_map`` runs ``fn(0) ... fn(n-1)`` in forked
worker processes when that is safe, else one after the other.

The identification's work is many small LAPACK and SuperLU calls driven from Python, so
threads do not overlap (the GIL; measured: two starts in threads took as long as in
sequence). Forked processes inherit the compiled terms without pickling them; only the
index goes out and the (small) fit result comes back, so the results are the same as in
sequence, in the same order. Each worker runs BLAS on one thread
(:func:`vfmodel.core.blas.one_thread_here`: the workers fill the cores). Processes are
used only where ``fork`` exists and the calling process runs no other thread (forking a
process with threads can deadlock on a lock held by one of them); otherwise, and for one
job, the calls run in sequence. ``VFMODEL_WORKERS`` (default: the usable cores, at most
the number of jobs) sets the number of processes; ``1`` turns the processes off. A job
that calls ``parallel_map`` itself runs those calls in sequence (the cores are taken by
the outer jobs).
"""

from __future__ import annotations

import gc
import multiprocessing as mp
import os
import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from typing import Any, TypeVar

from vfmodel.core.blas import one_thread_here
from vfmodel.core.progress import Progress, no_progress

__all__ = ["parallel_calls", "parallel_map", "workers"]

T = TypeVar("T")

_JOB: Callable[[int], Any] | None = None     # the job of the pool being run (inherited)
_IN_WORKER = False                           # True in a worker process: no nested pools


def workers(n_jobs: int, per_core: int = 1) -> int:
    """Processes for ``n_jobs`` independent jobs (1: run them in sequence), at most
    ``per_core`` per core."""
    env = os.environ.get("VFMODEL_WORKERS", "").strip()
    try:
        cores = int(env) if env else len(os.sched_getaffinity(0))
    except (ValueError, AttributeError):
        cores = os.cpu_count() or 1
    if n_jobs < 2 or cores < 2 or _IN_WORKER or "fork" not in mp.get_all_start_methods() \
            or threading.active_count() > 1 or mp.current_process().daemon:
        return 1
    return min(n_jobs, cores * per_core)


@contextmanager
def frozen_heap() -> Iterator[None]:
    """Within the block the objects that exist now are out of the garbage collector's
    reach (:func:`gc.freeze`): a forked worker's collections would otherwise write to
    every inherited object and copy its memory page by page."""
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def _run(k: int) -> Any:
    global _IN_WORKER
    _IN_WORKER = True       # the job's own parallel_map calls run in sequence here
    assert _JOB is not None
    return _JOB(k)


def parallel_map(fn: Callable[[int, Progress], T], n: int, progress: Progress = no_progress,
                 labels: Sequence[str] = (), total: int = 1,
                 first: Sequence[int] = (), per_core: int = 1) -> list[T]:
    """``[fn(k, progress) for k in range(n)]``; in worker processes the jobs get no
    progress callback and ``progress(labels[k], 0|total, total)`` is called here when a
    job starts and ends. ``first``: jobs to hand out before the others (the longest, so
    that the short ones fill the other workers meanwhile: three jobs of 2, 2 and 5 s on two
    workers take 7 s in index order, 5 s with the 5 s job first); the results keep the
    index order, and in sequence the jobs run in index order. ``per_core`` > 1 runs up to
    that many processes per core, sharing the cores, for jobs of similar length whose
    count is not a multiple of the cores (a detective round of three ~23-s refits on two
    cores: 46 s two by two, ~35 s all three at once)."""
    global _JOB
    order = list(dict.fromkeys([*first, *range(n)]))
    if sorted(order) != list(range(n)):
        raise ValueError(f"first: job indices in 0..{n - 1} expected, got {list(first)}")
    nw = workers(n, per_core)
    if nw == 1:
        return [fn(k, progress) for k in range(n)]
    for lab in labels:
        progress(lab, 0, total)
    _JOB = lambda k: fn(k, no_progress)      # noqa: E731  (read by the forked workers)
    try:
        with frozen_heap(), ProcessPoolExecutor(nw, mp_context=mp.get_context("fork"),
                                                 initializer=one_thread_here) as ex:
            done = dict(zip(order, ex.map(_run, order), strict=True))
        out = [done[k] for k in range(n)]
    finally:
        _JOB = None
    for lab in labels:
        progress(lab, total, total)
    return out


def parallel_calls(jobs: Sequence[Callable[[], T]]) -> list[T]:
    """``[job() for job in jobs]`` side by side where :func:`parallel_map` can (e.g. the
    figures of a report, each writing its own files)."""
    return parallel_map(lambda k, _prog: jobs[k](), len(jobs))
