"""Persistent forked workers that run the same jobs again and again with new arguments.

:func:`vfmodel.core.parallel.parallel_map` forks a pool per call: right for independent
fits of seconds, too dear for the terms of one least-squares evaluation (a fraction of a
second each, a hundred evaluations per fit): forking the ~1 GB process of a diagnosis for
every evaluation cost 32 s of system time in a 124-s diagnosis of independent bench 105.
A :class:`JobPool` forks its workers once; job ``k`` runs in worker ``k mod n`` at the first
call and then in the worker its measured times assign it to (dealt again at most three
times, :meth:`JobPool.map`), so whatever a job memoises (a term's last network transfer) stays
warm in that worker from one call to the next. Each call sends the argument to every
worker and gathers the results in job order; the same conditions as ``parallel_map``
decide whether processes are used at all (:func:`vfmodel.core.parallel.workers`), else the
jobs run here in sequence. An exception in a job is raised here.
"""

from __future__ import annotations

import multiprocessing as mp
import time
from collections.abc import Callable
from multiprocessing.connection import Connection
from types import TracebackType
from typing import Any, Generic, TypeVar

from vfmodel.core import parallel
from vfmodel.core.blas import one_thread_here

__all__ = ["JobPool", "balanced"]

REBALANCE_AT = (1, 3, 10)  # calls after which the jobs may be dealt again (summed times:
                           # a fit's first call is a residual, its Jacobians cost more)
REBALANCE_GAIN = 0.05      # the slowest worker's share must shrink by more than this
REBALANCE_MIN_S = 0.01     # ... and last longer than this (no moves for trivial jobs)

T = TypeVar("T")


def _serve(conn: Connection, fn: Callable[[int, Any], Any]) -> None:
    parallel._IN_WORKER = True          # a job's own parallel_map runs in sequence here
    one_thread_here()                   # the workers fill the cores
    while True:
        try:
            msg = conn.recv()
        except EOFError:
            return
        if msg is None:
            return
        arg, jobs = msg
        try:
            out, took = [], []
            for k in jobs:
                t0 = time.perf_counter()
                out.append(fn(k, arg))
                took.append(time.perf_counter() - t0)
        except BaseException as exc:        # any failure is re-raised in the parent
            try:
                conn.send((False, exc, None))
            except Exception:               # an exception that does not pickle
                conn.send((False, RuntimeError(f"{type(exc).__name__}: {exc}"), None))
            continue
        conn.send((True, out, took))


def balanced(took: list[float], n_workers: int) -> list[list[int]]:
    """Jobs (by index) per worker, longest first to the least loaded (LPT; Graham 1969:
    at most 4/3 of the best makespan)."""
    loads = [0.0] * n_workers
    groups: list[list[int]] = [[] for _ in range(n_workers)]
    for k in sorted(range(len(took)), key=lambda j: -took[j]):
        w = loads.index(min(loads))
        groups[w].append(k)
        loads[w] += took[k]
    return [sorted(g) for g in groups]


class JobPool(Generic[T]):
    """``fn(k, arg)`` for ``k`` in ``range(n_jobs)`` at every :meth:`map` call (a context
    manager; see the module docstring)."""

    def __init__(self, fn: Callable[[int, Any], T], n_jobs: int) -> None:
        self._fn = fn
        self._n_jobs = n_jobs
        self._conns: list[Connection] = []
        self._procs: list[Any] = []
        self._jobs: list[list[int]] = []
        self._calls = 0
        self._took = [0.0] * n_jobs         # each job's time summed over the calls so far
        nw = parallel.workers(n_jobs)
        if nw > 1:
            ctx = mp.get_context("fork")
            with parallel.frozen_heap():
                self._fork(ctx, fn, n_jobs, nw)

    def _fork(self, ctx: Any, fn: Callable[[int, Any], T], n_jobs: int, nw: int) -> None:
        for w in range(nw):
            jobs = list(range(w, n_jobs, nw))
            here, there = ctx.Pipe()
            p = ctx.Process(target=_serve, args=(there, fn), daemon=True)
            p.start()
            there.close()
            self._conns.append(here)
            self._procs.append(p)
            self._jobs.append(jobs)

    @property
    def processes(self) -> int:
        """Worker processes (0: the jobs run in sequence in this process)."""
        return len(self._procs)

    def map(self, arg: Any) -> list[T]:
        """``[fn(k, arg) for k in range(n_jobs)]``. After the calls of
        :data:`REBALANCE_AT` the jobs are dealt to the workers again by their summed
        times (:func:`balanced`) when that shortens the slowest worker's share by more
        than :data:`REBALANCE_GAIN` (the terms of a detective refit: the impedances take
        half of a record's time, and round-robin left one worker 12 % longer); a moved
        job's memo is rebuilt once."""
        if not self._procs:
            return [self._fn(k, arg) for k in range(self._n_jobs)]
        for c, jobs in zip(self._conns, self._jobs, strict=True):
            c.send((arg, jobs))
        out: list[Any] = [None] * self._n_jobs
        took = [0.0] * self._n_jobs
        error: BaseException | None = None
        for c, jobs in zip(self._conns, self._jobs, strict=True):
            ok, value, times = c.recv()
            if not ok:
                error = error or value
                continue
            for k, v, t in zip(jobs, value, times, strict=True):
                out[k] = v
                took[k] = t
        if error is not None:
            raise error
        self._calls += 1
        self._took = [a + b for a, b in zip(self._took, took, strict=True)]
        if self._calls in REBALANCE_AT:
            self._rebalance(self._took)
        return out

    def _rebalance(self, took: list[float]) -> None:
        now = max(sum(took[k] for k in g) for g in self._jobs)
        new = balanced(took, len(self._jobs))
        after = max(sum(took[k] for k in g) for g in new)
        if now > REBALANCE_MIN_S and after < (1 - REBALANCE_GAIN) * now:
            self._jobs = new

    def close(self) -> None:
        """Stop the workers (also at the end of a ``with`` block)."""
        for c in self._conns:
            try:
                c.send(None)
                c.close()
            except OSError:
                pass
        for p in self._procs:
            p.join(timeout=5)
            if p.is_alive():
                p.terminate()
        self._conns, self._procs, self._jobs = [], [], []

    def __enter__(self) -> JobPool[T]:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
