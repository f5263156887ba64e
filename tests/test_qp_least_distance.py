"""The enforcement program (vfmodel.fitting._qp.solve_qp) in its dual and primal forms
against an independent reference: the least-distance solution of Lawson and Hanson's
NNLS reduction."""

from __future__ import annotations

import time

import numpy as np
import pytest
from scipy import optimize, sparse

from vfmodel.fitting import _qp
from vfmodel.fitting._enforce import _DIRECT, _PRIMAL


def _ldp_reference(g: np.ndarray, h: np.ndarray) -> np.ndarray:
    """min ||x|| subject to g x >= h by NNLS (Lawson & Hanson, "Solving Least Squares
    Problems", 1974, ch. 23): u >= 0 minimising ||E u - f||, E = [g^T; h^T],
    f = (0, ..., 0, 1); x = -r[:n] / r[n] with r = E u - f."""
    n = g.shape[1]
    e = np.vstack([g.T, h[None, :]])
    f = np.zeros(n + 1)
    f[-1] = 1.0
    u, _ = optimize.nnls(e, f, maxiter=50 * e.shape[1])
    r = e @ u - f
    return np.asarray(-r[:n] / r[n])


def _program(n: int, m: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    g = rng.standard_normal((m, n))
    x0 = rng.standard_normal(n)
    h = g @ x0 - np.abs(rng.standard_normal(m))
    h[: m // 5] = g[: m // 5] @ x0  # a fifth of the cuts active at x0
    return g, h


@pytest.mark.parametrize(("n", "m", "primal"), [
    (40, 120, False),  # dual (one unknown per cut, a dense Gram matrix)
    (40, 360, False),
    (30, 360, True),   # primal: a tall program of cuts alone
])
def test_least_distance_solution(n: int, m: int, primal: bool) -> None:
    g, h = _program(n, m, seed=m + n)
    x, statuses = _qp.solve_qp(sparse.identity(n, format="csr"), n, g, h, None,
                               _PRIMAL if primal else _DIRECT, primal=primal)
    assert x is not None, statuses
    ref = _ldp_reference(g, h)
    assert np.min(g @ x - h) >= -1e-6 * np.max(np.abs(h))  # feasible
    np.testing.assert_allclose(x, ref, rtol=0, atol=1e-5 * float(np.linalg.norm(ref)))


def test_deadline_stops_a_program() -> None:
    # a deadline already past: no attempt starts; one a few ms ahead: Clarabel's own
    # time limit ends the program well before the unlimited solve of the same program
    g, h = _program(300, 1000, seed=7)
    args = (sparse.identity(300, format="csr"), 300, g, h, None, _DIRECT)
    x, statuses = _qp.solve_qp(*args, deadline=time.monotonic() - 1.0)
    assert x is None and statuses == ["time limit"]
    t0 = time.perf_counter()
    full, _ = _qp.solve_qp(*args)
    t_full = time.perf_counter() - t0
    assert full is not None
    t0 = time.perf_counter()
    cut, statuses = _qp.solve_qp(*args, deadline=time.monotonic() + 0.01 * t_full)
    t_cut = time.perf_counter() - t0
    assert cut is None and statuses[-1] == "time limit", statuses
    assert t_cut < 0.5 * t_full, (t_cut, t_full)
