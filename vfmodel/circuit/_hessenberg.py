"""Fast many-frequency solve of ``(G + s C) x = b`` by a shifted Hessenberg reduction.

With a real shift ``s0`` and ``A0 = G + s0 C``:

    G + s C = A0 (I + (s - s0) T),   T = A0^-1 C = Q H Q^T  (H upper Hessenberg, Q orthogonal)

so ``x = Q (I + (s - s0) H)^-1 Q^T A0^-1 b``. The reduction costs O(N^3) once per parameter
set; each frequency is then an upper-Hessenberg solve, O(N^2), done here for a batch of
frequencies at once (Gaussian elimination with partial pivoting between neighbouring rows,
vectorised over frequency). The adjoint ``A^-T c = A0^-T Q (I + (s - s0) H)^-T Q^T c`` uses
the same kernel on the reversed transpose (``J H^T J`` is upper Hessenberg).

References
----------
G. H. Golub, S. Nash, C. Van Loan, "A Hessenberg-Schur method for the problem AX + XB = C",
IEEE Trans. Autom. Control 24(6), 909-913, 1979 (Hessenberg form for shifted systems).
doi:10.1109/TAC.1979.1102170
A. J. Laub, "Efficient multivariable frequency response computations", IEEE Trans. Autom.
Control 26(2), 407-408, 1981. doi:10.1109/TAC.1981.1102605
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg as sla
from numpy.typing import NDArray

_CHUNK_BYTES = 32 << 20


def _hess_solve(hm: NDArray[np.float64], sig: NDArray[Any],
                rhs: NDArray[Any]) -> NDArray[np.complex128] | None:
    """Solve ``(I + sig_f hm) y_f = rhs_f`` for every f; None on a zero pivot.

    hm (N, N) upper Hessenberg; sig (n_f,); rhs (n_f, N, m) -> y (n_f, N, m).
    """
    n = hm.shape[0]
    m = np.eye(n)[None] + sig[:, None, None] * hm[None]
    r = np.array(rhs, dtype=complex)
    for k in range(n - 1):
        a = m[:, k, k:]
        b = m[:, k + 1, k:]
        swap = np.abs(b[:, 0]) > np.abs(a[:, 0])
        sw = swap[:, None]
        top = np.where(sw, b, a)
        bot = np.where(sw, a, b)
        rt = np.where(sw, r[:, k + 1], r[:, k])
        rb = np.where(sw, r[:, k], r[:, k + 1])
        piv = top[:, 0]
        if np.any(piv == 0):
            return None
        lk = bot[:, 0] / piv
        m[:, k, k:] = top
        m[:, k + 1, k:] = bot - lk[:, None] * top
        r[:, k] = rt
        r[:, k + 1] = rb - lk[:, None] * rt
    diag = np.diagonal(m, axis1=1, axis2=2)
    if np.any(diag == 0):
        return None
    y = np.empty_like(r)
    for k in range(n - 1, -1, -1):
        acc = r[:, k] - np.einsum("fj,fjm->fm", m[:, k, k + 1:], y[:, k + 1:])
        y[:, k] = acc / diag[:, k, None]
    return y


def hessenberg_solve(
    g: NDArray[Any], c: NDArray[Any], s: NDArray[np.complex128], b: NDArray[np.float64],
    cout: NDArray[np.float64], adjoint: bool,
) -> tuple[NDArray[np.complex128], NDArray[np.complex128] | None,
           NDArray[np.complex128] | None] | None:
    """``(h, x, lam)`` for all ``s`` (x, lam only with ``adjoint``); None if it breaks down."""
    w = np.abs(s.imag[s.imag != 0])
    s0 = float(np.sqrt(w.min() * w.max())) if w.size else 1.0
    a0 = g + s0 * c
    try:
        lu = sla.lu_factor(a0, check_finite=False)
        t = sla.lu_solve(lu, c, check_finite=False)
        if not np.all(np.isfinite(t)):
            return None
        hm, q = sla.hessenberg(t, calc_q=True, check_finite=False)
    except (np.linalg.LinAlgError, ValueError):
        return None
    n = g.shape[0]
    rb = q.T @ sla.lu_solve(lu, b, check_finite=False)          # (N, n_in)
    cq = cout.T @ q                                             # (n_out, N)
    qc = q.T @ cout                                             # (N, n_out)
    hm_t = hm.T[::-1, ::-1].copy()
    sig = s - s0
    chunk = max(1, _CHUNK_BYTES // (16 * n * n))
    hs, xs, ls = [], [], []
    for k0 in range(0, s.size, chunk):
        sg = sig[k0:k0 + chunk]
        y = _hess_solve(hm, sg, np.broadcast_to(rb, (sg.size, *rb.shape)))
        if y is None:
            return None
        hs.append(np.einsum("on,fni->foi", cq, y))
        if adjoint:
            xs.append(np.einsum("mn,fni->fmi", q, y))
            z = _hess_solve(hm_t, sg, np.broadcast_to(qc[::-1], (sg.size, *qc.shape)))
            if z is None:
                return None
            qz = np.einsum("mn,fno->fmo", q, z[:, ::-1])         # (f, N, n_out)
            lam = sla.lu_solve(lu, qz.transpose(1, 0, 2).reshape(n, -1), trans=1,
                               check_finite=False)
            ls.append(lam.reshape(n, sg.size, -1).transpose(1, 0, 2))
    h = np.concatenate(hs)
    if not adjoint:
        return h, None, None
    return h, np.concatenate(xs), np.concatenate(ls)
