"""All frequencies of a sparse solve at once (vfmodel.circuit._batched_lu via
``_solvers.solve_sparse``): the same solution as SuperLU per frequency, and the frequencies
where the kept pivot order fails are solved again with pivoting.

References: SuperLU per frequency (``_solvers._solve_each``) and the batched dense LAPACK
solve (``_solvers.solve_dense``)."""

from __future__ import annotations

import platform
from typing import cast

import numpy as np
import pytest
from numpy.typing import NDArray

import vfmodel.circuit._batched_lu as blu
import vfmodel.circuit._solvers as solvers
from benches.random_networks import random_rlc_network
from vfmodel.core.allocator import keep_large_blocks

F = np.logspace(2, 7, 80)


def _close(got: np.ndarray, want: np.ndarray, tol: float) -> bool:
    return bool(np.max(np.abs(got - want)) <= tol * np.max(np.abs(want)))


@pytest.mark.parametrize("seed", [3, 7, 19, 23])
def test_batched_equals_superlu_per_frequency(seed: int) -> None:
    # random RLC networks with a voltage source (a zero diagonal: pivoting is needed);
    # h, x and the adjoint lambda within 1e-9 of SuperLU per frequency and of dense LAPACK
    c = random_rlc_network(np.random.default_rng(seed), n_nodes=14, n_elements=40)
    g, cm = c.mna.matrices()
    s = cast(NDArray[np.complex128], 2j * np.pi * F)
    b = c.mna.input_matrix(["V1"])
    cout = c.mna.output_matrix(["n3", "i(V1)"])
    got = solvers._solve_batched(g, cm, s, b, cout, True)
    assert got is not None and got.x is not None and got.lam is not None
    for ref in (solvers._solve_each(g, cm, s, b, cout, True),
                solvers.solve_dense(g, cm, s, b, cout, True)):
        assert ref.x is not None and ref.lam is not None
        assert _close(got.h, ref.h, 1e-9)
        assert _close(got.x, ref.x, 1e-9)
        assert _close(got.lam, ref.lam, 1e-9)
    # without the adjoint: the same h
    plain = solvers.solve_sparse(g, cm, s, b, cout, False)
    assert plain.x is None and _close(plain.h, got.h, 1e-12)


def _vanishing_pivot(w0: float) -> tuple[np.ndarray, np.ndarray]:
    """A nonsingular 3x3 pencil whose second pivot in the natural order,
    ``G11 + s C11 - 1 / (s C00)``, is zero at ``s = j w0`` (C11 = -1/w0^2; det = -j w0)."""
    g = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]])
    c = np.diag([1.0, -1.0 / w0**2, 0.0])
    return g, c


def test_a_vanishing_static_pivot_is_detected_and_solved_again() -> None:
    w0 = 2 * np.pi * 1e4
    g, c = _vanishing_pivot(w0)
    s = 1j * np.array([w0 / 3, w0, 3 * w0, *np.geomspace(w0 / 10, w0 * 10, 20)])
    b = np.eye(3)[:, :1]
    cout = np.eye(3)[:, 2:]
    # natural order kept: the pivot at w0 is zero -> not finite -> flagged, others pass
    p = blu.plan((g != 0) | (c != 0), np.arange(3), np.arange(3))
    with np.errstate(all="ignore"):
        v = blu.factor(p, g, c, s)
        ok = blu.backward_ok(g, c, s, blu.solve(p, v, b.astype(complex)), b.astype(complex))
    assert not ok[1] and ok[0] and ok[2]
    # the solver's result at every frequency: that of dense LAPACK
    got = solvers.solve_sparse(g, c, s, b, cout, True)
    ref = solvers.solve_dense(g, c, s, b, cout, True)
    assert got.x is not None and ref.x is not None and got.lam is not None
    assert ref.lam is not None
    for a, r in ((got.h, ref.h), (got.x, ref.x), (got.lam, ref.lam)):
        assert np.all(np.abs(a - r) <= 1e-10 * np.max(np.abs(r), axis=(1, 2), keepdims=True))


def test_plan_stores_the_fill() -> None:
    # arrow matrix, dense first row and column: eliminating pivot 0 first fills the whole
    # matrix (n^2 entries); in reversed order there is no fill (3n - 2 entries)
    n = 6
    mask = np.eye(n, dtype=bool)
    mask[0, :] = mask[:, 0] = True
    assert blu.plan(mask, np.arange(n), np.arange(n)).rows.size == n * n
    rev = np.arange(n)[::-1]
    assert blu.plan(mask, rev, rev).rows.size == 3 * n - 2


def test_allocator_thresholds_are_set_with_glibc() -> None:
    # glibc's mallopt accepts the three settings (returns 1 each); elsewhere nothing is set
    expect = platform.system() == "Linux" and platform.libc_ver()[0] == "glibc"
    assert keep_large_blocks() is expect
