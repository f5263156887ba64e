"""BLAS threads of the library's pipelines and their workers: one, as in the CLI, whatever
numpy's default is (the thread count changes the rounding and, on two cores, the wall time
of an identification 3.6-fold: see :mod:`vfmodel.core.blas`)."""

from __future__ import annotations

import subprocess
import sys

PYTHON = sys.executable

# numpy loaded with up to four BLAS threads (OpenBLAS: at most the cores) before vfmodel,
# as in a user's session
_PRELUDE = ("import os; os.environ['OPENBLAS_NUM_THREADS'] = '4'; import numpy, threadpoolctl; "
            "n = lambda: max(i['num_threads'] for i in threadpoolctl.threadpool_info() "
            "if i['user_api'] == 'blas'); n0 = n(); ")


def _run(code: str) -> list[str]:
    out = subprocess.run([PYTHON, "-c", _PRELUDE + code], capture_output=True, text=True,
                         timeout=120, check=True).stdout
    return out.split()


def test_entry_points_run_on_one_thread_and_restore() -> None:
    code = ("from vfmodel.core.blas import capped_blas; "
            "f = capped_blas(lambda: (n(), os.environ['OPENBLAS_NUM_THREADS'])); "
            "print(*f(), n() == n0, os.environ['OPENBLAS_NUM_THREADS'])")
    assert _run(code) == ["1", "1", "True", "4"]


def test_override_by_environment() -> None:
    code = ("os.environ['VFMODEL_BLAS_THREADS'] = '2'; from vfmodel.core.blas import "
            "limited_blas; \nwith limited_blas(): print(n())")
    assert _run(code) == ["2"]


def test_pipelines_are_capped() -> None:
    code = ("from vfmodel.greybox.identify import identify; "
            "from vfmodel.pipeline.reproduce import reproduce; "
            "from vfmodel.pipeline.diagnose import run_diagnose; "
            "print(*(hasattr(f, '__wrapped__') for f in (identify, reproduce, run_diagnose)))")
    assert _run(code) == ["True", "True", "True"]


def test_workers_use_one_thread() -> None:
    """Forked workers of both pools: one thread each, whatever the parent has."""
    code = ("from vfmodel.core.job_pool import JobPool; "
            "from vfmodel.core.parallel import parallel_map; "
            "os.environ['VFMODEL_WORKERS'] = '2'; "
            "pm = parallel_map(lambda k, p: n(), 2); "
            "pool = JobPool(lambda k, a: n(), 2); jp = pool.map(None); "
            "print(pool.processes, *pm, *jp, n() == n0); pool.close()")
    assert _run(code) == ["2", "1", "1", "1", "1", "True"]
