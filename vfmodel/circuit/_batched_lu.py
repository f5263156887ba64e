"""Sparse LU of ``G + sC`` for many frequencies at once: one pivot order, one elimination
pattern, the arithmetic vectorised over the frequencies.

:func:`vfmodel.circuit._solvers.solve_sparse` calls SuperLU once per frequency. On the
grey-box networks (~120-190 unknowns, ~4 nonzeros per row) one factorisation and two
solves take ~0.1 ms, nearly all of it the call's own overhead, and the adjoint Jacobian of
a record needs them on ~350 frequencies: 43 ms per record, the largest share of a detective
refit. Here the pivot order of one SuperLU factorisation (at the geometric middle of the
band) is kept for every frequency, the fill of that elimination is found once
(:func:`plan`, cached per pattern and order), and each elimination step updates the values
of all frequencies in one array operation: the numeric work per frequency is that of the
sparse factorisation itself.

A static pivot order is not partial pivoting: a frequency where it meets a small pivot
could lose accuracy. Every solution is therefore checked by its residual
(``|A x - b| <= RESIDUAL_TOL (|A| |x| + |b|)`` in the infinity norm, the normwise backward
error of Rigal and Gaches, for ``x`` and for the adjoint ``lambda``); the frequencies that fail are
solved again by SuperLU with its own pivoting, so the result is a direct solve's to
rounding wherever it is returned.

References
----------
J. L. Rigal, J. Gaches, "On the compatibility of a given solution with the data of a
linear system", J. ACM 14(3), 543-548, 1967. doi:10.1145/321406.321416
T. A. Davis, *Direct Methods for Sparse Linear Systems*, SIAM, 2006, ch. 6 (left- and
right-looking LU, symbolic analysis).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]
ArrI = NDArray[np.intp]

RESIDUAL_TOL = 1e-12
"""Normwise backward error above which a frequency is solved again with pivoting (a
backward-stable factorisation reaches ~1e-16; a static order that loses more than four
digits of it is replaced)."""


@dataclass(frozen=True)
class Step:
    """Elimination of pivot ``k`` (positions in the value array): ``diag``; the column of L
    below it (``lcol``, rows ``lrows``); the row of U right of it (``urow``); the updated
    entries ``target = lcol[li] x urow[ui]``."""

    diag: int
    lrows: ArrI
    lcol: ArrI
    urow: ArrI
    target: ArrI
    li: ArrI
    ui: ArrI


@dataclass(frozen=True)
class Plan:
    """Elimination pattern of the permuted matrix ``A[pr][:, pc]`` (with fill).

    ``rows``, ``cols``: the permuted position of every stored entry; ``steps`` one per
    pivot; ``ucols[k]`` the rows and positions of U above the diagonal in column ``k`` (the
    back substitution), ``urows[k]`` the columns and positions right of it in row ``k``
    (the forward substitution with ``U^T``)."""

    n: int
    pr: ArrI
    pc: ArrI
    rows: ArrI
    cols: ArrI
    steps: tuple[Step, ...]
    ucols: tuple[tuple[ArrI, ArrI], ...]
    urows: tuple[tuple[ArrI, ArrI], ...]


@lru_cache(maxsize=64)
def _plan(n: int, pattern: bytes, pr_b: bytes, pc_b: bytes) -> Plan:
    mask = np.frombuffer(pattern, dtype=bool).reshape(n, n)
    pr = np.frombuffer(pr_b, dtype=np.intp)
    pc = np.frombuffer(pc_b, dtype=np.intp)
    m = mask[np.ix_(pr, pc)]
    # symbolic elimination (no pivoting): row patterns right of the diagonal, column
    # patterns below it, the fill of every step added
    below: list[set[int]] = [set((np.flatnonzero(m[k + 1:, k]) + k + 1).tolist()) for k in range(n)]
    right: list[set[int]] = [set((np.flatnonzero(m[k, k + 1:]) + k + 1).tolist()) for k in range(n)]
    for k in range(n):
        for i in below[k]:
            for j in right[k]:
                if i < j:
                    right[i].add(j)
                elif i > j:
                    below[j].add(i)
    entries = [(k, k) for k in range(n)]
    entries += [(i, k) for k in range(n) for i in below[k]]
    entries += [(k, j) for k in range(n) for j in right[k]]
    entries.sort()
    pos = {e: q for q, e in enumerate(entries)}
    rows = np.array([e[0] for e in entries], dtype=np.intp)
    cols = np.array([e[1] for e in entries], dtype=np.intp)
    steps = []
    for k in range(n):
        li = sorted(below[k])
        uj = sorted(right[k])
        tgt = [pos[(i, j)] for i in li for j in uj]
        steps.append(Step(pos[(k, k)], np.array(li, dtype=np.intp),
                          np.array([pos[(i, k)] for i in li], dtype=np.intp),
                          np.array([pos[(k, j)] for j in uj], dtype=np.intp),
                          np.array(tgt, dtype=np.intp),
                          np.repeat(np.arange(len(li), dtype=np.intp), len(uj)),
                          np.tile(np.arange(len(uj), dtype=np.intp), len(li))))
    above: list[list[int]] = [[] for _ in range(n)]
    for k in range(n):
        for j in right[k]:
            above[j].append(k)
    ucols = tuple((np.array(sorted(above[j]), dtype=np.intp),
                   np.array([pos[(i, j)] for i in sorted(above[j])], dtype=np.intp))
                  for j in range(n))
    urows = tuple((np.array(sorted(right[k]), dtype=np.intp),
                   np.array([pos[(k, j)] for j in sorted(right[k])], dtype=np.intp))
                  for k in range(n))
    return Plan(n, pr.copy(), pc.copy(), rows, cols, tuple(steps), ucols, urows)


def plan(mask: NDArray[np.bool_], pr: ArrI, pc: ArrI) -> Plan:
    """The elimination pattern of ``mask`` (n, n) under the row and column orders ``pr``,
    ``pc`` (cached: the networks of a fit share one pattern and order)."""
    n = mask.shape[0]
    return _plan(n, np.ascontiguousarray(mask, dtype=bool).tobytes(),
                 np.ascontiguousarray(pr, dtype=np.intp).tobytes(),
                 np.ascontiguousarray(pc, dtype=np.intp).tobytes())


def factor(p: Plan, g: ArrF, c: ArrF, s: ArrC) -> ArrC:
    """LU values (n_entries, n_f) of ``G + s C`` permuted, for every ``s`` (unit lower L
    below the diagonal, U on and above)."""
    gp = g[np.ix_(p.pr, p.pc)]
    cp = c[np.ix_(p.pr, p.pc)]
    v = (gp[p.rows, p.cols][:, None] + cp[p.rows, p.cols][:, None] * s[None, :]
         ).astype(complex)
    for st in p.steps:
        if st.lcol.size:
            v[st.lcol] /= v[st.diag]
            if st.urow.size:
                v[st.target] -= v[st.lcol][st.li] * v[st.urow][st.ui]
    return v


def solve(p: Plan, v: ArrC, b: ArrC) -> ArrC:
    """``x`` (n_f, n, n_rhs) of ``A x = b`` for right-hand sides ``b`` (n, n_rhs) shared by
    all frequencies."""
    n_f = v.shape[1]
    y = np.repeat(b[p.pr][:, None, :], n_f, axis=1)               # (n, n_f, n_rhs)
    for k, st in enumerate(p.steps):                              # L y = b (unit lower)
        if st.lrows.size:
            y[st.lrows] -= v[st.lcol][:, :, None] * y[k][None]
    for k in range(p.n - 1, -1, -1):                              # U x = y
        y[k] /= v[p.steps[k].diag][:, None]
        rows, q = p.ucols[k]
        if rows.size:
            y[rows] -= v[q][:, :, None] * y[k][None]
    x = np.empty_like(y)
    x[p.pc] = y
    return np.ascontiguousarray(x.transpose(1, 0, 2))


def solve_transposed(p: Plan, v: ArrC, c: ArrC) -> ArrC:
    """``lambda`` (n_f, n, n_rhs) of ``A^T lambda = c``: ``U^T w = c[pc]``, then
    ``L^T mu = w``, ``lambda[pr] = mu``."""
    n_f = v.shape[1]
    w = np.repeat(c[p.pc][:, None, :], n_f, axis=1)
    for k in range(p.n):                                          # U^T w = c (lower)
        w[k] /= v[p.steps[k].diag][:, None]
        cols, q = p.urows[k]
        if cols.size:
            w[cols] -= v[q][:, :, None] * w[k][None]
    for k in range(p.n - 1, -1, -1):                              # L^T mu = w (unit upper)
        st = p.steps[k]
        if st.lrows.size:
            w[k] -= np.einsum("af,afr->fr", v[st.lcol], w[st.lrows])
    lam = np.empty_like(w)
    lam[p.pr] = w
    return np.ascontiguousarray(lam.transpose(1, 0, 2))


def backward_ok(g: ArrF, c: ArrF, s: ArrC, x: ArrC, b: ArrC, transposed: bool = False
                ) -> NDArray[np.bool_]:
    """Per frequency: ``x`` (n_f, n, r) finite and its normwise backward error (Rigal and
    Gaches) ``|A x - b| / (|A| |x| + |b|)`` (infinity norms, ``|A| <= |G| + |s| |C|``) at
    most :data:`RESIDUAL_TOL` for every right-hand side (``A = G + sC``, or its
    transpose)."""
    gs = sp.csr_array(g.T if transposed else g)
    cs = sp.csr_array(c.T if transposed else c)
    n_f, n, r = x.shape
    xs = x.transpose(1, 0, 2).reshape(n, n_f * r)              # columns (f, r)
    sc = np.repeat(s, r)
    bs = np.tile(b, (1, n_f))
    with np.errstate(invalid="ignore", over="ignore"):
        err = np.abs(gs @ xs + sc[None, :] * (cs @ xs) - bs).max(axis=0)
        a_norm = _inf_norm(g) + np.abs(sc) * _inf_norm(c)
        bound = a_norm * np.abs(xs).max(axis=0) + np.abs(bs).max(axis=0)
        ok = np.isfinite(err) & (err <= RESIDUAL_TOL * bound)
    return np.asarray(ok.reshape(n_f, r).all(axis=1), dtype=bool)


def _inf_norm(a: ArrF) -> float:
    """The larger of the row and column sums of ``|a|`` (a bound for ``a`` and ``a^T``)."""
    m = np.abs(a)
    return float(max(m.sum(axis=1).max(initial=0.0), m.sum(axis=0).max(initial=0.0)))
