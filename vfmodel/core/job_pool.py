"""Persistent forked workers that run the same jobs again and again with new arguments.

:func:`vfmodel.core.parallel.parallel_map` forks a pool per call: right for independent
fits of seconds, too dear for the terms of one least-squares evaluation (a fraction of a
second each, a hundred evaluations per fit): forking the ~1 GB process of a diagnosis for
every evaluation cost 32 s of system time in a 124-s diagnosis of independent bench 105.
A :class:`JobPool` forks its workers once; job ``k`` always runs in worker ``k mod n``, so
whatever a job memoises (a term's last network transfer) stays warm in that worker from one
call to the next. Each call sends the argument to every worker and gathers the results in
job order; the same conditions as ``parallel_map`` decide whether processes are used at all
(:func:`vfmodel.core.parallel.workers`), else the jobs run here in sequence. An exception
in a job is raised here.
"""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Callable
from multiprocessing.connection import Connection
from types import TracebackType
from typing import Any, Generic, TypeVar

from vfmodel.core import parallel

__all__ = ["JobPool"]

T = TypeVar("T")


def _serve(conn: Connection, fn: Callable[[int, Any], Any], jobs: list[int]) -> None:
    parallel._IN_WORKER = True          # a job's own parallel_map runs in sequence here
    while True:
        try:
            arg = conn.recv()
        except EOFError:
            return
        if arg is None:
            return
        try:
            out = [fn(k, arg) for k in jobs]
        except BaseException as exc:        # any failure is re-raised in the parent
            try:
                conn.send((False, exc))
            except Exception:               # an exception that does not pickle
                conn.send((False, RuntimeError(f"{type(exc).__name__}: {exc}")))
            continue
        conn.send((True, out))


class JobPool(Generic[T]):
    """``fn(k, arg)`` for ``k`` in ``range(n_jobs)`` at every :meth:`map` call (a context
    manager; see the module docstring)."""

    def __init__(self, fn: Callable[[int, Any], T], n_jobs: int) -> None:
        self._fn = fn
        self._n_jobs = n_jobs
        self._conns: list[Connection] = []
        self._procs: list[Any] = []
        self._jobs: list[list[int]] = []
        nw = parallel.workers(n_jobs)
        if nw > 1:
            ctx = mp.get_context("fork")
            with parallel.frozen_heap():
                self._fork(ctx, fn, n_jobs, nw)

    def _fork(self, ctx: Any, fn: Callable[[int, Any], T], n_jobs: int, nw: int) -> None:
        for w in range(nw):
            jobs = list(range(w, n_jobs, nw))
            here, there = ctx.Pipe()
            p = ctx.Process(target=_serve, args=(there, fn, jobs), daemon=True)
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
        """``[fn(k, arg) for k in range(n_jobs)]``."""
        if not self._procs:
            return [self._fn(k, arg) for k in range(self._n_jobs)]
        for c in self._conns:
            c.send(arg)
        out: list[Any] = [None] * self._n_jobs
        error: BaseException | None = None
        for c, jobs in zip(self._conns, self._jobs, strict=True):
            ok, value = c.recv()
            if not ok:
                error = error or value
                continue
            for k, v in zip(jobs, value, strict=True):
                out[k] = v
        if error is not None:
            raise error
        return out

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
