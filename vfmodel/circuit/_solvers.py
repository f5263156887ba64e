"""The solver family of :class:`vfmodel.circuit.mna.MnaSystem`: direct and fast solves of
``H = Cout^T (G + sC)^-1 B`` over many frequencies, the pencil balancing and the tolerance
policy shared by every fast solve of a network in :mod:`vfmodel.circuit`.

Direct: ``dense`` (batched LAPACK) and ``sparse`` (SuperLU per frequency), exact to
rounding. Fast: ``hessenberg`` (:mod:`._hessenberg`), ``modal`` (one eigendecomposition of
the shifted pencil) and the pole-residue form of :mod:`vfmodel.circuit.transfer`. Every fast
solve is checked against direct solves (norm-wise relative agreement over the outputs at each
checked frequency) and replaced by a direct solve when it fails:

- :data:`CHECK_TOL` (1e-9) for :meth:`MnaSystem.solve` (any caller, any network);
- :data:`TRANSFER_CHECK_TOL` (1e-5) for :func:`vfmodel.circuit.transfer.transfer_on`, the
  bearing transfers of the identification, whose data are H1 estimates with percent-level
  uncertainty (the pole-residue form is then 10-100x faster than a direct solve per bin).

Generalized eigenproblems of ``(-G, C)`` are solved on the balanced pencil
(:func:`balance_pencil`); an eigenvalue ``alpha/beta`` is infinite when
``|alpha| >= ratio * ||Gs||/||Cs|| * |beta|`` (:func:`finite_mask`): ``INF_RATIO_POLES``
(1e12) for the natural frequencies (:func:`vfmodel.circuit.poles.network_poles`: keep every
physical pole), ``INF_RATIO_TRANSFER`` (1e10) for the pole-residue form (an eigenvalue that
large belongs in the constant term ``D``, fixed by a direct solve far above the band).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from vfmodel.circuit import _batched_lu as blu
from vfmodel.circuit._hessenberg import hessenberg_solve
from vfmodel.errors import CircuitError

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]

CHECK_TOL = 1e-9            # fast vs direct solves of MnaSystem.solve
TRANSFER_CHECK_TOL = 1e-5   # pole-residue transfer of the identification vs direct solves
INF_RATIO_POLES = 1e12      # infinite-eigenvalue threshold of network_poles
INF_RATIO_TRANSFER = 1e10   # infinite-eigenvalue threshold of the pole-residue form
_CHUNK_BYTES = 64 << 20     # memory for one batch of dense complex matrices


def balance_pencil(g: ArrF, c: ArrF) -> tuple[ArrF, ArrF, ArrF, ArrF]:
    """Diagonal balancing of the pencil ``(G, C)``: ``(Gs, Cs, dr, dc)`` with
    ``Gs = diag(dr) G diag(dc)`` (likewise ``Cs``), so that rows and columns of different
    physical units (A, V, S, H) have comparable norms; eigenvalues are unchanged."""
    dr = 1.0 / np.sqrt(np.maximum(np.abs(g).max(axis=1) + np.abs(c).max(axis=1), 1e-300))
    dc = 1.0 / np.sqrt(np.maximum(np.abs(g).max(axis=0) + np.abs(c).max(axis=0), 1e-300))
    return dr[:, None] * g * dc[None, :], dr[:, None] * c * dc[None, :], dr, dc


def finite_mask(alpha: NDArray[Any], beta: NDArray[Any], gs: ArrF, cs: ArrF,
                ratio: float) -> NDArray[np.bool_]:
    """Finite generalized eigenvalues ``alpha/beta`` of the balanced pencil ``(Gs, Cs)``:
    ``|alpha| < ratio * ||Gs|| / ||Cs|| * |beta|``."""
    scale = float(np.linalg.norm(gs)) / max(float(np.linalg.norm(cs)), 1e-300)
    return np.asarray(np.abs(alpha) < ratio * scale * np.abs(beta), dtype=bool)


@dataclass(frozen=True)
class Solution:
    """Batched solution: ``h (n_f, n_out, n_in)``; with the adjoint also ``x`` and ``lam``."""

    h: ArrC
    x: ArrC | None = None      # (n_f, N, n_in)  A^-1 B
    lam: ArrC | None = None    # (n_f, N, n_out) A^-T Cout
    method: str = "dense"



def _singular(where: str) -> CircuitError:
    return CircuitError(
        f"the MNA matrix is singular {where}: the network has no unique solution there "
        "(e.g. an LC loop resonating exactly, a node joined only by capacitors at DC, or "
        "a cut set of inductors and current sources)"
    )


def solve_dense(g: ArrF, c: ArrF, s: ArrC, b: ArrF, cout: ArrF, adjoint: bool) -> Solution:
    n = g.shape[0]
    chunk = max(1, _CHUNK_BYTES // (16 * n * n))
    hs: list[ArrC] = []
    xs: list[ArrC] = []
    ls: list[ArrC] = []
    for k in range(0, s.size, chunk):
        a = g[None] + s[k:k + chunk, None, None] * c[None]
        try:
            x = np.linalg.solve(a, np.broadcast_to(b, (a.shape[0], *b.shape)))
            lam = (np.linalg.solve(np.swapaxes(a, 1, 2),
                                   np.broadcast_to(cout, (a.shape[0], *cout.shape)))
                   if adjoint else None)
        except np.linalg.LinAlgError:
            raise _singular(f"between {s[k].imag / 2 / np.pi:.6g} Hz and "
                            f"{s[min(k + chunk, s.size) - 1].imag / 2 / np.pi:.6g} Hz") \
                from None
        hs.append(np.einsum("no,fni->foi", cout, x))
        if lam is not None:
            xs.append(np.asarray(x, dtype=np.complex128))
            ls.append(np.asarray(lam, dtype=np.complex128))
    h = np.concatenate(hs)
    if adjoint:
        return Solution(h, np.concatenate(xs), np.concatenate(ls), "dense")
    return Solution(h, method="dense")


def solve_sparse(g: ArrF, c: ArrF, s: ArrC, b: ArrF, cout: ArrF, adjoint: bool) -> Solution:
    """Sparse LU: from :data:`_BATCH_MIN` frequencies (none at DC) all frequencies at once
    (:func:`_solve_batched`), else SuperLU per frequency (:func:`_solve_each`)."""
    if s.size >= _BATCH_MIN and np.all(s != 0):
        out = _solve_batched(g, c, s, b, cout, adjoint)
        if out is not None:
            return out
    return _solve_each(g, c, s, b, cout, adjoint)


def _solve_each(g: ArrF, c: ArrF, s: ArrC, b: ArrF, cout: ArrF, adjoint: bool) -> Solution:
    """SuperLU per frequency, one factorisation for ``x`` and ``lambda``. The CSC pattern
    of ``G + sC`` (the union of both; at ``s = 0`` that of ``G``) is found once and only
    its values change per frequency: the matrix handed to SuperLU is the one
    ``csc(G) + s csc(C)`` gives, entry for entry, without rebuilding sparse objects."""
    n = g.shape[0]
    h = np.empty((s.size, cout.shape[1], b.shape[1]), complex)
    x = np.empty((s.size, n, b.shape[1]), complex) if adjoint else None
    lam = np.empty((s.size, n, cout.shape[1]), complex) if adjoint else None
    bc = np.asarray(b, dtype=complex)
    cc = np.asarray(cout, dtype=complex)
    patterns: dict[bool, tuple[ArrF, ArrF, NDArray[np.intc], NDArray[np.intc]]] = {}
    for k, sk in enumerate(s):
        dc_only = bool(sk == 0)
        if dc_only not in patterns:
            rows, cols, indptr = _csc((g != 0) if dc_only else ((g != 0) | (c != 0)))
            patterns[dc_only] = (g[rows, cols], c[rows, cols], rows, indptr)
        gv, cv, ind, ptr = patterns[dc_only]
        try:
            lu = _splu(gv + sk * cv, ind, ptr, n)
        except RuntimeError:
            raise _singular(f"at {sk.imag / 2 / np.pi:.6g} Hz") from None
        xk = lu.solve(bc)
        h[k] = cout.T @ xk
        if x is not None and lam is not None:
            x[k] = xk
            lam[k] = lu.solve(cc, trans="T")
    return Solution(h, x, lam, "sparse")


def _csc(mask: NDArray[np.bool_]) -> tuple[NDArray[np.intc], NDArray[np.intp],
                                            NDArray[np.intc]]:
    """Row indices, column indices and column pointers of the nonzeros of ``mask`` in
    canonical CSC order (column-major, sorted rows in each column)."""
    n = mask.shape[0]
    cols, rows = np.nonzero(mask.T)
    indptr = np.zeros(n + 1, dtype=np.intc)
    np.cumsum(np.bincount(cols, minlength=n), out=indptr[1:])
    return rows.astype(np.intc), cols, indptr


def _splu(vals: ArrC, ind: NDArray[np.intc], ptr: NDArray[np.intc], n: int) -> Any:
    """SuperLU factorisation of the canonical CSC matrix ``(vals, ind, ptr)``.

    Calls SuperLU's factorisation (``scipy.sparse.linalg._dsolve._superlu.gstrf``, the
    function :func:`scipy.sparse.linalg.splu` ends in, same default options) directly:
    ``splu`` first builds a sparse array and checks its format, which on the ~120-unknown
    grey-box networks costs 40 % of the factorisation itself (measured: 93 us vs 132 us
    per frequency for factorisation and two solves). The arrays built here are canonical by
    construction. Falls back to ``splu`` when that private entry point is missing or its
    signature differs (another SciPy version)."""
    global _GSTRF
    if _GSTRF is not None:
        try:
            return _GSTRF(n, vals.size, vals, ind, ptr, csc_construct_func=sp.csc_array,
                          ilu=False, options={})
        except TypeError:
            _GSTRF = None
    return spla.splu(sp.csc_array((vals, ind, ptr), shape=(n, n)))


try:  # the private entry point of splu (see _splu); absent -> the public path
    from scipy.sparse.linalg._dsolve._superlu import gstrf as _GSTRF
except ImportError:  # pragma: no cover - other SciPy layouts
    _GSTRF = None


def spot_check(h: ArrC, g: ArrF, c: ArrF, s: ArrC, b: ArrF, cout: ArrF) -> bool:
    """True when ``h`` agrees with direct solves at the band edges and the middle."""
    idx = np.unique([0, s.size // 2, s.size - 1])
    ref = solve_dense(g, c, s[idx], b, cout, False).h
    err = np.linalg.norm(h[idx] - ref, axis=(1, 2))
    scale = np.maximum(np.linalg.norm(ref, axis=(1, 2)), 1e-300)
    return bool(np.all(np.isfinite(h)) and np.all(err <= CHECK_TOL * scale))


def solve_hessenberg(g: ArrF, c: ArrF, s: ArrC, b: ArrF, cout: ArrF,
                      adjoint: bool) -> Solution | None:
    """Shifted Hessenberg solve (``_hessenberg``); None when it fails the spot check."""
    out = hessenberg_solve(g, c, s, b, cout, adjoint)
    if out is None or not spot_check(out[0], g, c, s, b, cout):
        return None
    return Solution(out[0], out[1], out[2], "hessenberg")


def solve_modal(g: ArrF, c: ArrF, s: ArrC, b: ArrF, cout: ArrF,
                 adjoint: bool) -> Solution | None:
    """Eigen-decomposition solve; None when it fails the spot check against direct solves."""
    w_nonzero = np.abs(s.imag[s.imag != 0])
    s0 = float(np.sqrt(w_nonzero.min() * w_nonzero.max())) if w_nonzero.size else 1.0
    a0 = g + s0 * c
    try:
        lu = sla.lu_factor(np.asarray(a0, dtype=complex), check_finite=False)
        t = sla.lu_solve(lu, c.astype(complex), check_finite=False)
        theta, v = np.linalg.eig(t)
        vinv = np.linalg.inv(v)
    except (np.linalg.LinAlgError, ValueError):
        return None
    if not (np.all(np.isfinite(theta)) and np.all(np.isfinite(vinv))):
        return None
    d = 1.0 / (1.0 + (s[:, None] - s0) * theta[None, :])        # (f, N)
    r = vinv @ sla.lu_solve(lu, b.astype(complex), check_finite=False)   # (N, n_in)
    lv = cout.T @ v                                              # (n_out, N)
    h = np.einsum("ok,fk,ki->foi", lv, d, r, optimize=True)
    if not spot_check(h, g, c, s, b, cout):
        return None
    if not adjoint:
        return Solution(h, method="modal")
    x = np.matmul(v, d[:, :, None] * r[None])                   # (f, N, n_in)
    # lambda = A^-T cout = K^T V^-T diag(d) V^T cout
    p = sla.lu_solve(lu, vinv.T, trans=1, check_finite=False)   # K^T V^-T
    q = v.T @ cout                                               # (N, n_out)
    lam = np.matmul(p, d[:, :, None] * q[None])                  # (f, N, n_out)
    return Solution(h, x, lam, "modal")


_BATCH_MIN = 16          # frequencies from which solve_sparse eliminates them all at once
_BATCH_CHUNK = 512       # frequencies per batch (memory: ~2,000 stored entries x 16 B each)


def _solve_batched(g: ArrF, c: ArrF, s: ArrC, b: ArrF, cout: ArrF,
                   adjoint: bool) -> Solution | None:
    """:mod:`._batched_lu`: SuperLU's pivot order at the band's geometric middle kept for
    every frequency; frequencies whose backward error fails are solved again one by one
    with pivoting (:func:`_solve_each`). None when the reference factorisation fails."""
    n = g.shape[0]
    w = np.abs(s)
    s_ref = 1j * float(np.sqrt(w.min() * w.max()))          # s != 0 here (solve_sparse)
    mask = (g != 0) | (c != 0)
    rows, cols, ptr = _csc(mask)
    try:
        lu = _splu(g[rows, cols] + s_ref * c[rows, cols], rows, ptr, n)
    except RuntimeError:
        return None
    # SuperLU: Pr A Pc = L U with Pr[perm_r[i], i] = 1, Pc[i, perm_c[i]] = 1
    p = blu.plan(mask, np.argsort(lu.perm_r), np.argsort(lu.perm_c))
    bc = np.asarray(b, dtype=complex)
    cc = np.asarray(cout, dtype=complex)
    xs, ls, ok = [], [], []
    for k in range(0, s.size, _BATCH_CHUNK):
        sk = s[k:k + _BATCH_CHUNK]
        with np.errstate(all="ignore"):
            v = blu.factor(p, g, c, sk)
            x = blu.solve(p, v, bc)
            good = blu.backward_ok(g, c, sk, x, bc)
            if adjoint:
                lam = blu.solve_transposed(p, v, cc)
                good &= blu.backward_ok(g, c, sk, lam, cc, transposed=True)
                ls.append(lam)
        xs.append(x)
        ok.append(good)
    x_all = np.concatenate(xs)
    lam_all = np.concatenate(ls) if adjoint else None
    h = np.einsum("no,fni->foi", cout, x_all)
    bad = np.flatnonzero(~np.concatenate(ok))
    if bad.size:
        redo = _solve_each(g, c, s[bad], b, cout, adjoint)
        h[bad] = redo.h
        if lam_all is not None:
            assert redo.x is not None and redo.lam is not None
            x_all[bad] = redo.x
            lam_all[bad] = redo.lam
    return Solution(h, x_all if adjoint else None, lam_all, "sparse")
