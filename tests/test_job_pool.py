"""Persistent forked workers (vfmodel.core.job_pool): results in job order, memos kept in
the workers between calls, errors raised in the caller, sequence without processes.

Runs in a fresh interpreter, because the pytest-xdist worker has threads (no fork there, by
design: :func:`vfmodel.core.parallel.workers`)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

from tests.conftest import REPO

SCRIPT = textwrap.dedent("""
    import json, os, sys
    sys.path.insert(0, {repo!r})
    from vfmodel.core.job_pool import JobPool

    calls = {{}}

    def job(k, arg):
        calls[k] = calls.get(k, 0) + 1          # lives in the worker that runs job k
        return k * arg, calls[k], os.getpid()

    def bad(k, arg):
        if k == 3:
            raise ValueError(f"job {{k}} failed on {{arg}}")
        return k

    out = {{"parent": os.getpid()}}
    os.environ["VFMODEL_WORKERS"] = "2"
    with JobPool(job, 5) as pool:
        out["processes"] = pool.processes
        out["first"] = pool.map(3)
        out["second"] = pool.map(10)
    out["calls_here"] = len(calls)
    try:
        with JobPool(bad, 4) as pool:
            pool.map(7)
        out["error"] = None
    except ValueError as exc:
        out["error"] = str(exc)
    os.environ["VFMODEL_WORKERS"] = "1"
    with JobPool(job, 3) as pool:
        out["seq_processes"] = pool.processes
        out["seq"] = pool.map(1)
    print(json.dumps(out))
""")


def test_job_pool_in_a_fresh_interpreter() -> None:
    if len(os.sched_getaffinity(0)) < 2:
        pytest.skip("one usable core: the pool runs in sequence by design")
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    run = subprocess.run([sys.executable, "-c", SCRIPT.format(repo=str(REPO))], env=env,
                         capture_output=True, text=True, timeout=120, check=True)
    out = json.loads(run.stdout.strip().splitlines()[-1])
    parent = out["parent"]
    assert out["processes"] == 2
    assert [v for v, _, _ in out["first"]] == [0, 3, 6, 9, 12]
    assert [v for v, _, _ in out["second"]] == [0, 10, 20, 30, 40]
    assert [n for _, n, _ in out["second"]] == [2] * 5     # each job's count went on
    pids = {pid for *_, pid in out["first"]}
    assert pids == {pid for *_, pid in out["second"]} and len(pids) == 2
    assert parent not in pids and out["calls_here"] == 0    # nothing ran in the parent
    assert out["error"] == "job 3 failed on 7"
    assert out["seq_processes"] == 0
    assert [v for v, _, _ in out["seq"]] == [0, 1, 2]
    assert {pid for *_, pid in out["seq"]} == {parent}
