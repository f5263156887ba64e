"""Clarabel's svec and its inverse (vfmodel.fitting._qp): the PSD blocks of the
enforcement program and the cvxpy fallback read the same matrix."""

from __future__ import annotations

import numpy as np
import pytest

from vfmodel.fitting._qp import svec, unsvec


@pytest.mark.parametrize("k", [1, 2, 5, 8])
def test_unsvec_inverts_svec(k: int) -> None:
    rng = np.random.default_rng(k)
    m = rng.standard_normal((k, k))
    m = m + m.T
    v = svec(m)
    assert v.size == k * (k + 1) // 2
    # svec preserves the Frobenius inner product (Clarabel's definition)
    assert float(v @ v) == pytest.approx(float(np.sum(m * m)), rel=1e-12)
    back = (unsvec(k) @ v).reshape(k, k, order="F")
    np.testing.assert_allclose(back, m, rtol=0, atol=1e-12)


@pytest.mark.parametrize(("shift", "ok"), [(0.0, True), (-2e-9, True), (-2e-8, False)])
def test_feasible_reads_the_cones_of_a_primal_program(shift: float, ok: bool) -> None:
    """``_feasible`` (the check that keeps a feasible "AlmostSolved" point) on constraints
    b - a x in (nonnegative 2) x (PSD 3x3), tolerance 1e-8: the smallest slack ``shift``
    in the nonnegative part, in the PSD part (eigenvalues 2, 1, shift) or in both.
    Reference: the slacks and eigenvalues set by construction (x = 0: b is the slack)."""
    from scipy import sparse

    from vfmodel.fitting._qp import _feasible

    q, _ = np.linalg.qr(np.random.default_rng(0).standard_normal((3, 3)))
    low = q @ np.diag([2.0, 1.0, shift]) @ q.T
    for nonneg, psd in (([1.0, shift], np.eye(3)), ([1.0, 0.5], low), ([1.0, shift], low)):
        b = np.concatenate([nonneg, svec(psd)])
        a = sparse.csc_matrix((b.size, 4))
        assert _feasible(a, b, [-2, 3], np.zeros(4), 1e-8) is ok
