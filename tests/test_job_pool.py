"""Persistent forked workers (vfmodel.core.job_pool): results in job order, memos kept in
the workers between calls, errors raised in the caller, sequence without processes."""

from __future__ import annotations

import os

import pytest

from vfmodel.core.job_pool import JobPool


def test_results_in_job_order_and_state_stays_in_the_worker(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("VFMODEL_WORKERS", "2")
    calls: dict[int, int] = {}

    def job(k: int, arg: int) -> tuple[int, int, int]:
        calls[k] = calls.get(k, 0) + 1          # lives in the worker that runs job k
        return k * arg, calls[k], os.getpid()

    with JobPool(job, 5) as pool:
        if pool.processes < 2:
            pytest.skip("no fork or fewer than 2 usable cores")
        first = pool.map(3)
        second = pool.map(10)
    assert [v for v, _, _ in first] == [0, 3, 6, 9, 12]
    assert [v for v, _, _ in second] == [0, 10, 20, 30, 40]
    assert [n for _, n, _ in second] == [2] * 5           # each job's count went on
    assert {pid for *_, pid in first} == {pid for *_, pid in second}
    assert os.getpid() not in {pid for *_, pid in first}
    assert calls == {}                                    # nothing ran here


def test_an_error_in_a_job_is_raised_here(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("VFMODEL_WORKERS", "2")

    def job(k: int, arg: int) -> int:
        if k == 3:
            raise ValueError(f"job {k} failed on {arg}")
        return k

    with JobPool(job, 4) as pool, pytest.raises(ValueError, match="job 3 failed on 7"):
        pool.map(7)


def test_one_worker_runs_in_sequence(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("VFMODEL_WORKERS", "1")
    with JobPool(lambda k, a: (k + a, os.getpid()), 3) as pool:
        assert pool.processes == 0
        out = pool.map(1)
    assert [v for v, _ in out] == [1, 2, 3]
    assert {pid for _, pid in out} == {os.getpid()}
