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
