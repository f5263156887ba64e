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
    # OpenBLAS runs on at most the cores: two where the caller had two or more
    code = ("os.environ['VFMODEL_BLAS_THREADS'] = '2'; from vfmodel.core.blas import "
            "limited_blas; \nwith limited_blas(): print(n() == min(2, n0))")
    assert _run(code) == ["True"]


def test_restored_after_an_error_and_nested_blocks() -> None:
    """An exception inside a capped call restores the caller's count and environment; a
    nested block of the same count changes nothing and leaves the outer one in force."""
    code = ("from vfmodel.core.blas import capped_blas, limited_blas; "
            "f = capped_blas(lambda: 1 / 0); \n"
            "try: f()\nexcept ZeroDivisionError: pass\n"
            "print(n() == n0, os.environ['OPENBLAS_NUM_THREADS']); \n"
            "with limited_blas():\n"
            "    with limited_blas(): inner = n()\n"
            "    print(inner, n())\n"
            "print(n() == n0)")
    assert _run(code) == ["True", "4", "1", "1", "True"]


def test_pipelines_are_capped() -> None:
    code = ("from vfmodel.greybox.identify import identify; "
            "from vfmodel.pipeline.reproduce import reproduce; "
            "from vfmodel.pipeline.diagnose import run_diagnose; "
            "from vfmodel.pipeline.fit_job import run_fit; "
            "from vfmodel.fitting import vector_fit, check_passivity, enforce_passivity; "
            "print(*(hasattr(f, '__wrapped__') for f in (identify, reproduce, run_diagnose, "
            "run_fit, vector_fit, check_passivity, enforce_passivity)))")
    assert _run(code) == ["True"] * 7


def test_a_fit_runs_on_one_thread_and_warns_at_the_callers_line() -> None:
    """The fit sees one thread; its warnings name the caller's line, not the wrapper's."""
    code = ("import warnings; import vfmodel.fitting._relocate as r; seen = []; "
            "orig = r.iterate; "
            "r.iterate = lambda *a, **k: (seen.append(n()), orig(*a, **k))[1]; "
            "from vfmodel.fitting import vector_fit; "
            "from vfmodel.core.frequency_data import FrequencyData; "
            "f = numpy.linspace(1e6, 1e9, 50); "
            # H data: one relocation does not converge and warns (an S fit's lighter
            # out-of-band relocation converges on these noise-free data)
            "fd = FrequencyData(f, (1 / (1 + 1j * f / 3e8))[:, None, None], kind='H'); "
            "w = warnings.catch_warnings(record=True); got = w.__enter__(); "
            "warnings.simplefilter('always'); "
            "vector_fit(fd, order=1, max_iterations=1); w.__exit__(None, None, None); "
            "print(set(seen), n() == n0, got[0].filename, got[0].lineno)")
    assert _run(code) == ["{1}", "True", "<string>", "1"]


def test_workers_use_one_thread() -> None:
    """Forked workers of both pools: one thread each, whatever the parent has."""
    code = ("from vfmodel.core.job_pool import JobPool; "
            "from vfmodel.core.parallel import parallel_map; "
            "os.environ['VFMODEL_WORKERS'] = '2'; "
            "pm = parallel_map(lambda k, p: n(), 2); "
            "pool = JobPool(lambda k, a: n(), 2); jp = pool.map(None); "
            "print(pool.processes, *pm, *jp, n() == n0); pool.close()")
    assert _run(code) == ["2", "1", "1", "1", "1", "True"]
