"""BLAS threads: the same cap for the CLI, the library's pipelines and their workers.

The grey-box identification and the detective are many small dense solves driven from
Python, run side by side in forked workers (:mod:`vfmodel.core.parallel`,
:mod:`vfmodel.core.job_pool`). More than one BLAS thread per process only contends for the
cores, and the thread count changes the rounding of BLAS reductions, which a long
least-squares identification can carry into a different end point. Measured on
independent bench 111 (2 cores, ``reproduce(sections=(6,))`` called from Python): 184 s
with numpy's default two OpenBLAS threads against 51 s with one, and rotating peak errors
of 0.49-0.99 % against the CLI's 1.02-1.98 %: the library and the CLI disagreed. With the
cap the library call takes the CLI's time and gives its numbers. The vector fit follows
the rounding too (2 of the 29 vfbench files of up to 4 ports fit another order on numpy's
default two threads: diff_2xthru 38 against 40 poles capped, mlin 21 against 22), so its
public functions are wrapped as well.

:func:`blas_threads` is the count (1, or ``VFMODEL_BLAS_THREADS``); :func:`limited_blas`
applies it to the BLAS libraries already loaded (threadpoolctl; 4 us per call when nothing
is to change, about 20 us otherwise: small fits of a few milliseconds are wrapped too) and,
through the environment, to those loaded later; :func:`capped_blas` wraps a public entry
point in it; :func:`one_thread_here` is called by each forked worker.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

__all__ = ["BLAS_ENV", "blas_threads", "capped_blas", "limited_blas", "one_thread_here"]

BLAS_ENV = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
            "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")

F = TypeVar("F", bound=Callable[..., Any])


def blas_threads() -> int:
    """BLAS threads of vfmodel's work: 1, or ``VFMODEL_BLAS_THREADS`` when set (whatever
    OPENBLAS_NUM_THREADS etc. say)."""
    try:
        return max(1, int(os.environ.get("VFMODEL_BLAS_THREADS", "1")))
    except ValueError:
        return 1


# thread counts of the limited_blas blocks open in this process (BLAS thread limits are
# per process, so threads of one process share the stack: a block that ends restores the
# count for all of them)
_ACTIVE: list[str] = []


@contextlib.contextmanager
def limited_blas(n: int | None = None) -> Iterator[None]:
    """Within the block BLAS runs on ``n`` threads (default :func:`blas_threads`): the
    libraries loaded now through threadpoolctl, those loaded later through the environment;
    both are restored at the end. Nothing is changed (a few microseconds) within a block
    of the same count or when the environment and every loaded library already have it
    (``make test``, the benchmarks: one thread set before numpy loads)."""
    k = str(blas_threads() if n is None else max(1, int(n)))
    if (_ACTIVE and _ACTIVE[-1] == k) or _already(k):
        _ACTIVE.append(k)
        try:
            yield
        finally:
            _ACTIVE.pop()
        return
    saved = {v: os.environ.get(v) for v in BLAS_ENV}
    os.environ.update(dict.fromkeys(BLAS_ENV, k))
    _ACTIVE.append(k)
    try:
        if "numpy" in sys.modules:
            with _controller().limit(limits=int(k), user_api="blas"):
                yield
        else:
            yield
    finally:
        _ACTIVE.pop()
        for v, old in saved.items():
            if old is None:
                os.environ.pop(v, None)
            else:
                os.environ[v] = old


def _already(k: str) -> bool:
    """OpenBLAS's environment (what a library loaded later reads) says ``k`` threads and
    every BLAS library loaded runs on ``k``."""
    if any(os.environ.get(v) != k for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")):
        return False
    if "numpy" not in sys.modules:
        return True
    return all(lc.num_threads == int(k) for lc in _controller().lib_controllers
               if lc.user_api == "blas")


_CONTROLLER: list[Any] = []  # [threadpoolctl controller, len(sys.modules) when made]


def _controller() -> Any:
    """threadpoolctl's view of the BLAS libraries loaded (7 ms to make, 10 us per limit
    after): made again when modules were imported since (a library loaded since, e.g.
    scipy's OpenBLAS beside numpy's, is then seen)."""
    if not _CONTROLLER or _CONTROLLER[1] != len(sys.modules):
        from threadpoolctl import ThreadpoolController

        _CONTROLLER[:] = [ThreadpoolController(), len(sys.modules)]
    return _CONTROLLER[0]


def capped_blas(fn: F) -> F:
    """``fn`` run within :func:`limited_blas` (a public entry point of a pipeline)."""
    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with limited_blas():
            return fn(*args, **kwargs)
    return wrapper  # type: ignore[return-value]


def one_thread_here() -> None:
    """One BLAS thread for the rest of this process (a forked worker: the workers fill the
    cores)."""
    os.environ.update(dict.fromkeys(BLAS_ENV, "1"))
    if "numpy" in sys.modules and not _already("1"):
        _controller().limit(limits=1, user_api="blas")  # applied when made, kept
