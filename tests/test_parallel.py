"""Independent fits in forked processes (vfmodel.core.parallel): the same results as in
sequence, in the same order, and processes really used where they are allowed.

Reference: the sequential run of the same calls (``VFMODEL_WORKERS=1``). Runs in a fresh
interpreter, because the pytest-xdist worker has threads (no fork there, by design)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

from tests.conftest import REPO

SCRIPT = textwrap.dedent("""
    import json, os, sys, time
    sys.path.insert(0, {repo!r})
    from benches.small_dataset import make_small_dataset
    from vfmodel.core.io_dataset import read_dataset
    from vfmodel.core.parallel import parallel_map, workers
    from vfmodel.greybox.identify import identify

    def job(k, prog):
        return (k, os.getpid())

    def slow(k, prog):
        time.sleep(0.5)
        return (k, os.getpid())

    out = {{"parent": os.getpid()}}
    ds = read_dataset(make_small_dataset({root!r}, seed=1, n_samples=4096))
    for w in ("1", "2"):
        os.environ["VFMODEL_WORKERS"] = w
        out["workers" + w] = workers(2)
        out["map" + w] = parallel_map(job, 3)
        out["first" + w] = parallel_map(job, 3, first=[2])
        out["per_core" + w] = parallel_map(slow, 3, per_core=2)
        idf = identify(ds)
        out["params" + w] = [float(v) for v in idf.params.values]
        out["chi2" + w] = [s.chi2_red for s in idf.stages]
    print(json.dumps(out))
""")


def test_forked_fits_equal_the_sequential_ones(tmp_path: Path) -> None:
    code = SCRIPT.format(repo=str(REPO), root=str(tmp_path / "small"))
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, timeout=600, check=False)
    assert run.returncode == 0, run.stderr[-2000:]
    out = json.loads(run.stdout.strip().splitlines()[-1])
    assert out["workers1"] == 1 and out["workers2"] == 2
    # order kept; in sequence the parent runs the jobs, with 2 workers other processes
    assert [k for k, _ in out["map1"]] == [0, 1, 2] == [k for k, _ in out["map2"]]
    # a job handed out first: results still in index order
    assert [k for k, _ in out["first1"]] == [0, 1, 2] == [k for k, _ in out["first2"]]
    assert {pid for _, pid in out["map1"]} == {out["parent"]}
    # two per core on two cores: three jobs at once, each in its own process
    assert [k for k, _ in out["per_core2"]] == [0, 1, 2]
    assert len({pid for _, pid in out["per_core2"]} - {out["parent"]}) == 3
    assert out["parent"] not in {pid for _, pid in out["map2"]}
    # the same arithmetic in another process: identical to rounding (1e-12 relative)
    for a, b in zip(out["params1"], out["params2"], strict=True):
        assert abs(a - b) <= 1e-12 * max(abs(a), 1e-300), (a, b)
    for a, b in zip(out["chi21"], out["chi22"], strict=True):
        assert abs(a - b) <= 1e-12 * abs(a), (a, b)


def test_first_must_name_jobs() -> None:
    import pytest

    from vfmodel.core.parallel import parallel_map

    with pytest.raises(ValueError, match="first"):
        parallel_map(lambda k, _p: k, 3, first=[3])


def test_parallel_calls_returns_results_in_order() -> None:
    from functools import partial

    from vfmodel.core.parallel import parallel_calls

    assert parallel_calls([partial(pow, 2, k) for k in range(5)]) == [1, 2, 4, 8, 16]
