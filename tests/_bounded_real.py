"""The bounded-real lemma's optimum for fixed poles (reference for the enforcement tests).

With the poles fixed, an S model C (sI - A)^-1 B + D with A stable is passive with
||H||_inf <= gamma exactly when a symmetric P exists with

    [[A^T P + P A, P B, C^T], [B^T P, -gamma I, D^T], [C, D, -gamma I]] <= 0,

which is linear in (P, C, D) for fixed (A, B) (Coelho, Phillips, Silveira, "A convex
programming approach for generating guaranteed passive approximations to tabulated
frequency-data", IEEE TCAD 23(2), 2004). Minimising the enforcement's objective (the
weighted change of the response from ``model`` on the data frequencies) over it gives the
least change any passive model with these poles can make.
"""

from __future__ import annotations

import cvxpy as cp
import numpy as np
from scipy import sparse

from vfmodel import RationalModel
from vfmodel.fitting._enforce import _entry_systems, _objective, _to_residues
from vfmodel.fitting._hamiltonian import scaled_model


def _blocks(poles: np.ndarray, n: int) -> list[tuple[int, int, int]]:
    """(first state, first basis column, parts) per pole of RationalModel.to_state_space's
    realisation: n states of a real pole, 2 n of a pair (real, then imaginary part)."""
    out: list[tuple[int, int, int]] = []
    k = state = 0
    while k < poles.size:
        parts = 1 if poles[k].imag == 0 else 2
        out.append((state, k, parts))  # basis columns follow the poles one to one
        k, state = k + parts, state + parts * n
    return out


def bounded_real_optimum(model: RationalModel, f: np.ndarray, h: np.ndarray,
                          gamma: float) -> RationalModel:
    """The passive model (||H||_inf <= gamma) with the poles of ``model`` nearest to ``h``
    in the enforcement's objective (uniform weights, the same scaled unknowns)."""
    n = model.n_in
    col, systems, _ = _entry_systems(model, f, h, "uniform", True, 1.0)
    r_blocks = _objective(systems)
    n_b = col.size
    # the project's realisation of the model with frequency scaled by w0, each pole's
    # states scaled to a unit Gramian diagonal (sqrt(2 |Re p|)), which the SDP needs
    scaled, w0, _ = scaled_model(model)
    ss = scaled.to_state_space()
    blocks = _blocks(scaled.poles, n)
    scale = np.concatenate([np.full(parts * n, np.sqrt(2 * abs(scaled.poles[k].real)))
                            for _, k, parts in blocks])
    a, b, c0 = ss.a, ss.b * scale[:, None], ss.c / scale[None, :]
    ns = a.shape[0]
    # C = C0 + G x: x[(i n + j) n_b + k] is the scaled change of basis column k, entry (i, j)
    rows: list[int] = []
    cols: list[int] = []
    vals: list[float] = []
    for state, k, parts in blocks:
        for m in range(parts):
            st = state + m * n
            for i in range(n):
                for j in range(n):
                    rows.append(i * ns + st + j)
                    cols.append((i * n + j) * n_b + k + m)
                    vals.append(1.0 / (col[k + m] * w0 * scale[st]))
    g_c = sparse.csr_matrix((vals, (rows, cols)), shape=(n * ns, n * n * n_b))
    d_idx = [(i * n + j) * n_b + n_b - 1 for i in range(n) for j in range(n)]
    g_d = sparse.csr_matrix((np.full(n * n, 1.0 / col[-1]), (range(n * n), d_idx)),
                            shape=(n * n, n * n * n_b))
    x = cp.Variable(n * n * n_b)
    p = cp.Variable((ns, ns), symmetric=True)
    c_mat = cp.reshape(c0.ravel() + g_c @ x, (n, ns), order="C")
    d_mat = cp.reshape(model.dd.ravel() + g_d @ x, (n, n), order="C")
    lmi = cp.bmat([[a.T @ p + p @ a, p @ b, c_mat.T],
                   [b.T @ p, -gamma * np.eye(n), d_mat.T],
                   [c_mat, d_mat, -gamma * np.eye(n)]])
    prob = cp.Problem(cp.Minimize(cp.norm(r_blocks @ x)), [0.5 * (lmi + lmi.T) << 0])
    prob.solve(solver=cp.CLARABEL)
    assert prob.status == cp.OPTIMAL, prob.status
    xb = np.transpose(np.asarray(x.value).reshape(n, n, n_b), (2, 0, 1)) / col[:, None, None]
    dr, dd = _to_residues(model.poles, xb, n)
    return RationalModel(model.poles, model.residues + dr, model.dd + dd, kind="S",
                         z0=model.z0)
