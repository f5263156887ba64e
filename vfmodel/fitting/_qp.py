"""The convex program of passivity enforcement (:mod:`vfmodel.fitting._enforce`) handed
to Clarabel directly: minimise ||R x||^2 subject to linear cuts, the asymptotic
condition on D (a small semidefinite cone) and exact per-frequency conditions
(semidefinite cones, :class:`PsdBlock`).

Building the matrices here instead of through a modelling layer (cvxpy) keeps the cost
of a program to the interior-point solve itself: at the scale of an 8-port model with
100 poles (6,000 unknowns, hundreds of dense cut rows) the modelling layer spent about
10 s and 500 MB per program on canonicalisation alone.

Clarabel's standard form: minimise 1/2 x^T P x + q^T x subject to A x + s = b, s in a
product of cones; a positive semidefinite k x k constraint M(x) >= 0 is the cone of the
vectorised upper triangle of M (column-major, off-diagonal entries scaled by sqrt 2).

Reference: P. J. Goulart, Y. Chen, "Clarabel: An interior-point solver for conic programs
with quadratic objectives", arXiv:2405.12762 (2024).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import sparse

FloatArray = NDArray[np.float64]

_SQRT2 = float(np.sqrt(2.0))


@dataclass(frozen=True)
class DConstraint:
    """Asymptotic condition on the D entries ``x[index]`` (row-major n x n, scaled by
    ``1 / col``): S: sigma_max(D0 + X / col) <= 1 - margin; Z, Y: the symmetric part of
    D0 + X / col >= floor (PSD)."""

    kind: str
    d0: FloatArray  # (n, n), in units of the response scale
    index: NDArray[np.intp]  # (n * n,) positions of the D entries in x
    col: float
    bound: float  # 1 - margin (S) or margin * d_size (Z, Y)


@dataclass(frozen=True)
class PsdBlock:
    """A semidefinite constraint ``svec(M(x)) = b - a x`` in the k x k PSD cone
    (``a``: rows of the svec entries, one column per unknown x)."""

    a: sparse.csr_matrix
    b: FloatArray
    k: int


def svec(m: FloatArray) -> FloatArray:
    """Clarabel's vectorised upper triangle of symmetric m (..., k, k): column-major,
    off-diagonal entries scaled by sqrt 2."""
    k = m.shape[-1]
    c, r = np.tril_indices(k)  # (c, r) with r <= c, ordered by c then r
    return np.asarray(m[..., r, c] * np.where(r == c, 1.0, _SQRT2), dtype=float)


def unsvec(k: int) -> sparse.csr_matrix:
    """The map from svec (:func:`svec`) to the
    column-major vectorised symmetric k x k matrix."""
    c, r = np.tril_indices(k)
    scale = np.where(r == c, 1.0, 1.0 / _SQRT2)
    pos = np.arange(r.size)
    rows = np.concatenate([c * k + r, (r * k + c)[r != c]])
    cols = np.concatenate([pos, pos[r != c]])
    vals = np.concatenate([scale, scale[r != c]])
    return sparse.csr_matrix((vals, (rows, cols)), shape=(k * k, r.size))


def _svec_index(r: int, c: int) -> int:
    """Position of entry (r, c), r <= c, in the column-major upper triangle."""
    return c * (c + 1) // 2 + r


def _psd_rows(dc: DConstraint, n_var: int) -> PsdBlock:
    """The semidefinite block s = b - A x = svec(M(x)) of the D condition."""
    n = dc.d0.shape[0]
    rows: list[int] = []
    cols: list[int] = []
    vals: list[float] = []
    if dc.kind == "S":  # M = [[c I, D], [D^T, c I]]
        k = 2 * n
        m0 = np.zeros((k, k))
        m0[:n, :n] = m0[n:, n:] = dc.bound * np.eye(n)
        m0[:n, n:] = dc.d0
        m0[n:, :n] = dc.d0.T
        for i in range(n):
            for j in range(n):
                rows.append(_svec_index(i, n + j))
                cols.append(int(dc.index[i * n + j]))
                vals.append(-_SQRT2 / dc.col)
    else:  # M = (D + D^T) / 2 - floor I
        k = n
        m0 = 0.5 * (dc.d0 + dc.d0.T) - dc.bound * np.eye(n)
        for i in range(n):
            for j in range(n):
                r, c = min(i, j), max(i, j)
                rows.append(_svec_index(r, c))
                cols.append(int(dc.index[i * n + j]))
                vals.append(-(1.0 if r == c else 0.5 * _SQRT2) / dc.col)
    a = sparse.csr_matrix((vals, (rows, cols)), shape=(k * (k + 1) // 2, n_var))
    return PsdBlock(a, svec(m0), k)


def _block_inverse(r_blocks: sparse.spmatrix, size: int) -> sparse.csr_matrix:
    """Inverse of a block-diagonal matrix of invertible square blocks of ``size``."""
    r = sparse.csr_matrix(r_blocks)
    blocks = [np.linalg.inv(r[k:k + size, k:k + size].toarray())
              for k in range(0, r.shape[0], size)]
    return sparse.block_diag(blocks, format="csr")


def solve_qp(
    r_blocks: sparse.spmatrix,
    block: int,
    a: FloatArray,
    b: FloatArray,
    d_constraint: DConstraint | None,
    attempts: tuple[dict[str, Any], ...],
    scale: float = 1.0,
    psd: tuple[PsdBlock, ...] = (),
    primal: bool | None = None,
    deadline: float | None = None,
) -> tuple[FloatArray | None, list[str]]:
    """Minimise ||R x||^2 subject to ``a x >= b``, ``d_constraint`` and the blocks ``psd``.

    Settings in ``attempts`` are tried in turn until Clarabel reports "Solved"; when none
    does, the last "AlmostSolved" point is returned (the caller certifies the model it
    leads to independently). ``scale``: the expected ||R x||^2 (e.g. the previous
    program's of a cutting-plane loop, whose optimum only grows as cuts are added), so
    that one solve is well scaled (see below). ``primal``: solve the program itself
    (:func:`_primal_form`) instead of its dual (:func:`_dual_form`); default: with
    ``psd`` blocks only. ``deadline`` (``time.monotonic()``): none of it is built once
    that has passed, and Clarabel stops at it (:func:`_run`). Returns (x or None, the
    statuses).
    """
    import clarabel

    if deadline is not None and time.monotonic() > deadline:
        return None, ["time limit"]
    n_var = a.shape[1]
    # variables y = R x: the objective becomes ||y||^2 (P = I), the cuts a R^-1
    rinv = _block_inverse(r_blocks, block)
    a_parts: list[sparse.spmatrix] = [sparse.csc_matrix(-(rinv.T @ a.T).T)]
    b_parts: list[FloatArray] = [-np.asarray(b, dtype=float)]
    dims: list[int] = [-int(a.shape[0])]  # per cone: -rows (nonnegative) or k (k x k PSD)
    blocks = list(psd)
    if d_constraint is not None:
        if d_constraint.d0.shape[0] == 1 and d_constraint.kind != "S":
            j = int(d_constraint.index[0])
            row = sparse.csc_matrix(([-1.0 / d_constraint.col], ([0], [j])), shape=(1, n_var))
            a_parts.append(row)
            b_parts.append(np.array([float(d_constraint.d0[0, 0]) - d_constraint.bound]))
            dims.append(-1)
        else:
            blocks.insert(0, _psd_rows(d_constraint, n_var))
    for blk in blocks:
        a_parts.append(blk.a)
        b_parts.append(blk.b)
        dims.append(blk.k)
    cones: list[Any] = [clarabel.NonnegativeConeT(-k) if k < 0 else
                        clarabel.PSDTriangleConeT(k) for k in dims]
    a_parts[1:] = [sparse.csc_matrix(part @ rinv) for part in a_parts[1:]]
    a_all = sparse.vstack(a_parts, format="csr")
    b_all = np.concatenate(b_parts)
    # objective scale: Clarabel's duality-gap test is relative to max(1, |objective|),
    # so an optimum of 1e-18 (a change of 1e-9, lossless data) passes for "Solved" at
    # any point whose objective is below the tolerance (measured: changes of 4e-6 for an
    # optimum of 2e-9 on ntwk1.s2p). A program whose objective ends below _SMALL_OBJECTIVE
    # is solved again with P and q divided by the squared size of its solution (the same
    # minimiser, an objective near 1/2), at most _RESCALES times; a rescaled program that
    # ends without a solution (the O(1) data of the D cone divided by a tiny scale can
    # stall the solver) leaves the previous solution. Well-scaled programs are solved once
    # (an a-priori scale from the cuts alone blew the Gram matrix of an ill-conditioned
    # 3-point program up to 1e14 and its solves to 200 iterations).
    solve_once = _primal_form(a_all, b_all, cones, dims, attempts, deadline) if \
        (bool(psd) if primal is None else primal) else \
        _dual_form(a_all, b_all, cones, attempts, deadline)
    statuses: list[str] = []
    scale = scale if np.isfinite(scale) and scale > 0 else 1.0
    best: FloatArray | None = None
    for _ in range(_RESCALES + 1):
        y, status = solve_once(scale)
        statuses += status
        if y is None:
            break
        best = rinv @ y
        size2 = float(y @ y)
        if status[-1] not in _OPTIMAL or 0.5 * size2 / scale >= _SMALL_OBJECTIVE or size2 == 0:
            break
        scale = size2
    return best, statuses


_Form = Callable[[float], tuple[FloatArray | None, list[str]]]


def _dual_form(a_all: sparse.csr_matrix, b_all: FloatArray, cones: list[Any],
               attempts: tuple[dict[str, Any], ...], deadline: float | None) -> _Form:
    """The program as its dual: y = -A^T z with z in the (self-dual) cones minimising
    1/2 z^T (A A^T) z + b^T z -- as many unknowns as constraints (a dense Gram matrix),
    few next to the unknowns of an 8-port model with 100 poles (6,000)."""
    a_dense = a_all.toarray()
    gram = sparse.triu(sparse.csc_matrix(a_dense @ a_dense.T), format="csc")
    m = a_dense.shape[0]
    neg_eye = -sparse.identity(m, format="csc")

    def solve_once(scale: float) -> tuple[FloatArray | None, list[str]]:
        return _run(gram / scale, b_all / scale, neg_eye, np.zeros(m), cones, attempts,
                    lambda z: -(a_dense.T @ z), deadline)

    return solve_once


def _primal_form(a_all: sparse.csr_matrix, b_all: FloatArray, cones: list[Any],
                 dims: list[int], attempts: tuple[dict[str, Any], ...],
                 deadline: float | None) -> _Form:
    """The program itself: minimise 1/2 ||y||^2 / scale subject to A y + s = b, s in the
    cones. Used with the exact per-frequency cones, whose dual Clarabel did not solve
    accurately: on the delayed-line model of tests/test_fit_robust.py
    (OPENBLAS_CORETYPE=Sandybridge) every dual program with them ended "AlmostSolved"
    with cones violated by up to 1.3e-5 (the frequency was cut again, 30 programs without
    a certificate); in the primal form the same cones held (smallest eigenvalue above
    -1e-9) and the model was certified after 8 programs (cones after one cut).

    An "AlmostSolved" end whose point satisfies every constraint to the first attempt's
    feasibility tolerance (times max(1, |b|)) is kept without the further attempts
    (:func:`_feasible`): Clarabel's reduced tolerances then bound only the objective's
    gap (5e-5 relative), and the model is certified independently. Measured on a 2-port
    bandpass filter's program (188 unknowns, 1,482 cuts, two PSD cones): the first
    attempt ended "AlmostSolved" in 1.7 s, feasible (smallest slack 3e-14), objective
    within 2e-8 and point within 2e-5 of the second attempt's "Solved" (2.0 s more)."""
    a = sparse.csc_matrix(a_all)
    n = a.shape[1]
    eye = sparse.identity(n, format="csc")
    tol = float(attempts[0].get("tol_feas", 1e-8)) * max(1.0, float(np.max(np.abs(b_all))))

    def solve_once(scale: float) -> tuple[FloatArray | None, list[str]]:
        return _run(eye / scale, np.zeros(n), a, b_all, cones, attempts, lambda x: x,
                    deadline, accept=lambda x: _feasible(a, b_all, dims, x, tol))

    return solve_once


_SMALL_OBJECTIVE = 1e-6  # scaled objective below which the program is solved again
_FEASIBLE = "AlmostSolved, feasible"  # an "AlmostSolved" point kept by _feasible
_OPTIMAL = ("Solved", _FEASIBLE)
_RESCALES = 2


def _run(
    p: sparse.csc_matrix,
    q: FloatArray,
    a: sparse.csc_matrix,
    b: FloatArray,
    cones: list[Any],
    attempts: tuple[dict[str, Any], ...],
    to_y: Callable[[FloatArray], FloatArray],
    deadline: float | None = None,
    accept: Callable[[FloatArray], bool] | None = None,
) -> tuple[FloatArray | None, list[str]]:
    """One Clarabel program, settings tried in turn until "Solved" (else the last
    "AlmostSolved" point); ``to_y`` maps its solution to y. Returns y and the statuses.
    ``deadline`` (``time.monotonic()``): Clarabel's own time limit is set to the time left,
    and no further attempt starts once it has passed. ``accept``: an "AlmostSolved"
    solution it accepts ends the attempts (status ``_FEASIBLE``)."""
    import clarabel

    statuses: list[str] = []
    almost: FloatArray | None = None
    for extra in attempts:
        settings = clarabel.DefaultSettings()
        settings.verbose = False
        for key, val in extra.items():
            setattr(settings, key, val)
        if deadline is not None:
            left = deadline - time.monotonic()
            if left <= 0:
                statuses.append("time limit")
                break
            settings.time_limit = left
        try:
            sol = clarabel.DefaultSolver(p, q, a, b, cones, settings).solve()
        except Exception as err:  # the solver's own errors (e.g. a failed factorisation)
            statuses.append(f"error {err}")
            continue
        status = str(sol.status)
        statuses.append(status)
        sol_x = np.asarray(sol.x, dtype=float)
        if not np.all(np.isfinite(sol_x)):
            continue
        y = to_y(sol_x)
        if status == "Solved":
            return y, statuses
        if status == "AlmostSolved":
            if accept is not None and accept(sol_x):
                statuses[-1] = _FEASIBLE
                return y, statuses
            almost = y
    return almost, statuses


def _feasible(a: sparse.csc_matrix, b: FloatArray, dims: list[int], x: FloatArray,
              tol: float) -> bool:
    """Whether x satisfies ``b - a x`` in the cones ``dims`` (-rows: nonnegative; k: the
    svec of a k x k PSD matrix, :func:`svec`) to ``tol`` (smallest entry / eigenvalue)."""
    s = b - a @ x
    i = 0
    for k in dims:
        if k < 0:
            part, i = s[i:i - k], i - k
            if part.size and float(part.min()) < -tol:
                return False
            continue
        m = k * (k + 1) // 2
        mat = (unsvec(k) @ s[i:i + m]).reshape(k, k, order="F")
        i += m
        if float(np.linalg.eigvalsh(mat)[0]) < -tol:
            return False
    return True
