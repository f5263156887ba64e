"""Passivity enforcement by residue (and D) perturbation: a cutting-plane quadratic program.

For fixed poles the response is linear in the residues and D. The perturbation
dH(s) = sum_b phi_b(s) X_b uses a real basis that keeps conjugate pairs conjugate:
phi = 1/(s - p) for a real pole; 1/(s - p) + 1/(s - p*) and j/(s - p) - j/(s - p*) for the
real and imaginary parts of the upper residue of a pair; phi = 1 for D.

Passivity at one frequency is a convex condition on H that is the intersection of half
spaces, one per unit vector (pair):

- Z, Y: lambda_min((H + H^H)/2) >= 0  <=>  Re(v^H H v) >= 0 for every unit v;
- S: sigma_max(H) <= 1  <=>  Re(u^H H v) <= 1 for every unit u, v.

Each such half space, for a vector (pair) taken from the eigen- (singular value)
decomposition of the current model at a violating frequency, is an exact linear
constraint on the total perturbation (a cut). This is the linearised constraint of
Gustavsen and Semlyen [1] and Gustavsen [2] (first-order eigenvalue / singular value
perturbation), used here as a cutting plane [3]: every program starts from the original
model with all cuts found so far, so the change is minimised for the final constraint
set instead of accumulated step by step. With cuts alone the program is a QP, which
Clarabel solves quickly and reliably.

A cut is one supporting half space at the current vectors; near a curved boundary whose
vectors rotate from program to program, cuts creep and the violation returns (Kelley's
method converges slowly). A frequency cut twice before therefore gets the exact
condition instead, a semidefinite cone (S: [[c I, H], [H^H, c I]] >= 0; Z, Y: the
Hermitian part minus the margin >= 0; both in their real form), for small port counts, few
unknowns and a bounded number of cones (their cost grows quickly with the size).

The objective, the weighted change of H on the data frequencies, is the sum over entries
(i, j) of ||W_ij Phi x_ij||^2 = ||R_ij x_ij||^2 with Phi = QR (R_ij square), so the program
size does not grow with the number of data frequencies. Variables are scaled by the
largest basis magnitude on the data and by the response size, so they are O(1).

New violations are found on a dense frequency grid (cheap, vectorised) and, once the grid
is clean, by the Hamiltonian test, whose band edges, interior points and worst point give
further cuts; the loop ends when the Hamiltonian test certifies passivity.

References
----------
.. [1] B. Gustavsen, A. Semlyen, "Enforcing passivity for admittance matrices approximated by
   rational functions", IEEE Trans. Power Syst. 16(1) (2001), doi:10.1109/59.910778.
.. [2] B. Gustavsen, "Fast passivity enforcement for pole-residue models by perturbation of
   residue matrix eigenvalues", IEEE Trans. Power Deliv. 23(4) (2008),
   doi:10.1109/TPWRD.2007.915883.
.. [3] J. E. Kelley, "The cutting-plane method for solving convex programs", J. SIAM 8(4)
   (1960), doi:10.1137/0108053.
.. [4] S. Grivet-Talocia, B. Gustavsen, "Passive Macromodeling", Wiley (2016),
   doi:10.1002/9781119140931.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from scipy import sparse

from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.progress import Progress, no_progress
from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import InputError, PassivityError, SolverError
from vfmodel.fitting._qp import DConstraint, PsdBlock, solve_qp, svec, unsvec
from vfmodel.fitting.passivity import PassivityReport, check_passivity

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

_INTERIOR = 8  # cut frequencies inside each band of the Hamiltonian test
_MAX_NEW = 60  # new cut frequencies per program at most (from the grid)
_NEAR = 1
_DROP = 0.05  # cuts with more slack than this (relative to the response) are dropped...
# ...once they have been that slack in this many programs in a row. Dropping a cut at its
# first slack program made the cuts cycle: bench test_delay_extraction_cuts_the_order's
# 7-pole line model (sigma 43-86 above the band) was certified after 10 programs with one
# BLAS kernel and not within 30 with another (OPENBLAS_CORETYPE=Sandybridge), its
# violation returning where dropped cuts had held it.
_DROP_AFTER = 3
# exact conditions (semidefinite cones, _cones) where cuts keep failing: at a frequency cut
# this many times before; cones of at most _CONE_SIZE rows and columns (S: 4 ports; Z, Y: 8),
# at most _CONE_ROWS svec rows in all, programs of at most _CONE_UNKNOWNS unknowns. Large
# programs with cones are costly (primal form, :mod:`vfmodel.fitting._qp`): the 8-port
# HFSS export of data/vfbench (S, 32 x 32 cones, 528 svec rows each) took 246 s with 40
# cones (up to 90 s per program) and 46 s with 3, against 12 s with cuts alone (11
# programs); a random 8-port Y model with 43 basis functions (2752 unknowns) took 28.5 s
# with 8 cones, against 2.2 s with cuts alone (6 programs either way). The delayed line of
# tests/test_fit_robust.py (2 ports, 36 rows a cone) used 21-31 cones over five BLAS
# kernels and 7-10 programs; with 1000 rows 8-13, with 500 10-15. Cones after one cut:
# 7-9 programs, more cones; after three: 8-10, but enforced errors on data/vfbench up to
# 5 % larger (mlin...kirschning.s2p 2.41 against 2.29 times the fit error).
_CONE_AFTER = 2
_CONE_SIZE = 16
_CONE_ROWS = 2000
_CONE_UNKNOWNS = 500
_ALL_BELOW = 0
_COMBOS = 3  # mixtures among at most this many of the lowest columns (cuts grow as k^2)
_MAX_TARGET = 1e-3  # deepest cut margin (relative)
_GRID_LOG = 1500  # log-spaced grid points over the poles +- 2 decades
# Tikhonov term relative to the objective's scale: keeps directions the data barely sees
# (poles outside the data band) bounded and the program well conditioned
_TIKHONOV = 1e-5
# Objective forms and Clarabel settings tried in turn until one ends "optimal". The result
# is certified by the Hamiltonian test, not by the solver.
_TOL = {"tol_gap_abs": 1e-12, "tol_gap_rel": 1e-8, "tol_feas": 1e-8}
_ATTEMPTS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("norm", _TOL),
    ("sumsq", _TOL),
    ("sumsq", {"static_regularization_constant": 1e-7, "max_step_fraction": 0.95}),
    ("norm", {"tol_gap_abs": 1e-6, "tol_gap_rel": 1e-6, "tol_feas": 1e-6}),
)


# settings of the direct Clarabel program (the dual of a least-norm problem, whose
# objective can be tiny: a relative gap only), tried in turn
_DIRECT: tuple[dict[str, Any], ...] = (
    {"tol_gap_abs": 1e-30, "tol_gap_rel": 1e-10, "tol_feas": 1e-9},
    {"tol_gap_abs": 1e-30, "tol_gap_rel": 1e-8, "tol_feas": 1e-8,
     "static_regularization_constant": 1e-7, "max_step_fraction": 0.95},
)


# programs of cuts alone are solved in their dual form (one unknown per cut, a dense
# Gram matrix: few unknowns next to the thousands of an 8-port model's residues), except
# when the cuts outnumber the unknowns by _PRIMAL_TALL and _PRIMAL_ROWS: the dense dual
# of a few hundred cuts costs seconds per program (wr2p2,line.s2p with out-of-band poles:
# 372-666 cuts on 60 unknowns, 0.2-5.5 s each, 26 s for --passive), the primal of its
# unknowns milliseconds
_PRIMAL_TALL = 4.0
_PRIMAL_ROWS = 250


# settings of the primal program (with exact per-frequency cones; its objective is scaled
# near 1/2), tried in turn
_PRIMAL: tuple[dict[str, Any], ...] = (
    {"tol_gap_abs": 1e-8, "tol_gap_rel": 1e-6, "tol_feas": 1e-9,
     "chordal_decomposition_enable": False},
    {"tol_gap_abs": 1e-8, "tol_gap_rel": 1e-6, "tol_feas": 1e-8,
     "static_regularization_constant": 1e-7, "max_step_fraction": 0.95},
)


def _basis(poles: ComplexArray, s: NDArray[np.complexfloating], with_d: bool) -> ComplexArray:
    """Real-parameter basis (n_s, n_b) of the perturbation (see module docstring)."""
    cols: list[ComplexArray] = []
    k = 0
    while k < poles.size:
        p = poles[k]
        if p.imag == 0:
            cols.append(1.0 / (s - p))
            k += 1
        else:
            a, b = 1.0 / (s - p), 1.0 / (s - np.conj(p))
            cols += [a + b, 1j * (a - b)]
            k += 2
    if with_d:
        cols.append(np.ones_like(s))
    return np.column_stack(cols) if cols else np.zeros((s.size, 0), complex)


def _to_residues(poles: ComplexArray, x: FloatArray, n: int) -> tuple[ComplexArray, FloatArray]:
    """Residue and D perturbations from the real parameters x (n_b, n, n)."""
    dr = np.zeros((poles.size, n, n), complex)
    k = j = 0
    while k < poles.size:
        if poles[k].imag == 0:
            dr[k] = x[j]
            k, j = k + 1, j + 1
        else:
            dr[k] = x[j] + 1j * x[j + 1]
            dr[k + 1] = np.conj(dr[k])
            k, j = k + 2, j + 2
    dd = x[j] if j < x.shape[0] else np.zeros((n, n))
    return dr, np.asarray(dd, dtype=float)


@dataclass(frozen=True)
class _Setup:
    """Fixed data of the programs: the original model, scalings and objective blocks."""

    model: RationalModel
    perturb_d: bool
    margin: float
    h0: float  # response scale (1 for S)
    col: FloatArray  # basis column scale (n_b,)
    r_blocks: sparse.csr_matrix  # block-diagonal objective, entry (i, j) block = R_ij
    size_floor: float  # floor of the per-frequency response size (Z, Y), units of h0
    d_size: float  # size of the response at infinity (Z, Y), units of h0

    @property
    def n(self) -> int:
        return self.model.n_in

    @property
    def n_b(self) -> int:
        return int(self.col.size)

    def phi(self, f_hz: FloatArray) -> ComplexArray:
        """Scaled basis at frequencies in Hz; ``inf`` keeps the D column only."""
        fin = np.isfinite(f_hz)
        out = np.zeros((f_hz.size, self.n_b), complex)
        out[fin] = _basis(self.model.poles, 2j * np.pi * f_hz[fin], self.perturb_d)
        if self.perturb_d:
            out[~fin, -1] = 1.0
        return np.asarray(out / self.col, dtype=complex)

    def apply(self, x: FloatArray) -> RationalModel:
        """Model with the scaled parameters x (n * n * n_b,) added."""
        n = self.n
        xb = np.transpose(x.reshape(n, n, self.n_b), (2, 0, 1)) * (self.h0 / self.col)[
            :, None, None
        ]
        dr, dd = _to_residues(self.model.poles, xb, n)
        m = self.model
        return RationalModel(m.poles, m.residues + dr, m.dd + dd, m.ee, m.kind, m.z0)


def _response(model: RationalModel, f_hz: FloatArray) -> ComplexArray:
    """H(j 2 pi f) without E (the E condition is separate); D at ``inf``."""
    fin = np.isfinite(f_hz)
    h = np.empty((f_hz.size, model.n_out, model.n_in), complex)
    h[fin] = model.evaluate_s(2j * np.pi * f_hz[fin]) - (2j * np.pi * f_hz[fin])[
        :, None, None
    ] * model.ee[None]
    h[~fin] = model.dd
    return h


def _margins(kind: str, h: ComplexArray) -> FloatArray:
    """Margin per frequency: min eig (H + H^H)/2 (Z, Y) or 1 - sigma_max (S)."""
    if kind == "S":
        return np.asarray(1.0 - np.linalg.svd(h, compute_uv=False)[:, 0], dtype=float)
    herm = 0.5 * (h + np.conj(np.swapaxes(h, 1, 2)))
    return np.asarray(np.linalg.eigvalsh(herm)[:, 0], dtype=float)


def _pairs(
    left: ComplexArray, right: ComplexArray, low: NDArray[np.bool_]
) -> tuple[ComplexArray, ComplexArray]:
    """Unit vector pairs for the cuts at one frequency: the low columns (eigenvectors or
    singular pairs) and, when several are low, their mixtures (a_i + w a_j) / sqrt 2,
    w in {1, -1, j, -j}: near a matrix with several active eigenvalues (e.g. a nearly
    lossless S, all singular values at one) the supporting hyperplanes form a family that
    the vectors alone sample too coarsely. Mixtures are formed among the ``_COMBOS`` most
    violating columns only (columns come ordered worst first): with all of them, an
    8-port model gave 120 cuts per frequency and programs of thousands of rows."""
    lo_l, lo_r = left[:, low], right[:, low]
    cols_l, cols_r = [lo_l], [lo_r]
    k = min(lo_l.shape[1], _COMBOS)
    for i in range(k):
        for j in range(i + 1, k):
            for w in (1.0, -1.0, 1j, -1j):
                cols_l.append(((lo_l[:, i] + w * lo_l[:, j]) / np.sqrt(2))[:, None])
                cols_r.append(((lo_r[:, i] + w * lo_r[:, j]) / np.sqrt(2))[:, None])
    return np.hstack(cols_l), np.hstack(cols_r)


def _cuts(
    setup: _Setup,
    current: RationalModel,
    f_hz: FloatArray,
    h_orig: ComplexArray,
    target: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Cuts ``A x >= b`` at frequencies ``f_hz`` from the current model's vectors.

    Z, Y: Re(v^H (H0 + dH) v) >= margin * size for the eigenvectors v of the Hermitian part
    of the current model with eigenvalue below 10 margin * size (size = ||H0||_2 floored);
    S: Re(u^H (H0 + dH) v) <= 1 - margin for the singular pairs with sigma above
    1 - 10 margin. Every row is divided by the size, so all rows are O(1). ``target`` is
    the margin required per frequency (>= margin; raised where cuts keep being violated).
    """
    n, h0 = setup.n, setup.h0
    h_cur = _response(current, f_hz) / h0
    h_orig = h_orig / h0
    phi = setup.phi(f_hz)
    s_kind = setup.model.kind == "S"
    if s_kind:
        u, sv, vh = np.linalg.svd(h_cur)
        v_all = np.conj(np.swapaxes(vh, 1, 2))
        low = sv > 1.0 - 10 * setup.margin
        size = np.ones(f_hz.size)
    else:
        herm = 0.5 * (h_cur + np.conj(np.swapaxes(h_cur, 1, 2)))
        lam, u = np.linalg.eigh(herm)
        v_all = u
        size = np.maximum(np.linalg.norm(h_orig, 2, axis=(1, 2)), setup.size_floor)
        low = lam < 10 * setup.margin * size[:, None]
    rows: list[FloatArray] = []
    rhs: list[FloatArray] = []
    for k in np.flatnonzero(np.any(low, axis=1)):
        a, b = _pairs(u[k], v_all[k], low[k])
        # Re(a^H dH b) = sum_ij Re(conj(a_i) b_j dH_ij), dH_ij = phi @ x_ij
        c = np.conj(a)[:, None, :] * b[None, :, :]  # (n, n, n_vec)
        row = np.real(c[:, :, :, None] * phi[k][None, None, None, :])
        row = np.moveaxis(row, 2, 0).reshape(a.shape[1], -1)
        lhs0 = np.real(np.einsum("iv,ij,jv->v", np.conj(a), h_orig[k], b))
        if s_kind:  # Re(a^H (H0 + dH) b) <= 1 - margin
            rows.append(-row)
            rhs.append(-(1.0 - target[k] - lhs0))
        else:  # Re(a^H (H0 + dH) a) >= margin * size
            rows.append(row / size[k])
            rhs.append((target[k] * size[k] - lhs0) / size[k])
    if not rows:
        return np.zeros((0, n * n * setup.n_b)), np.zeros(0)
    return np.vstack(rows), np.concatenate(rhs)


@lru_cache(maxsize=16)
def _embedding(kind: str, n: int) -> tuple[FloatArray, int]:
    """The linear part of the exact condition at one frequency as a map from
    z = [Re H (row-major), Im H] (2 n^2) to svec(M) (T, svec length x 2 n^2), and k.

    S: M = [[c I, E], [E^T, c I]] >= 0 with E = [[Re H, -Im H], [Im H, Re H]] (4n x 4n),
    i.e. sigma_max(H) <= c: E is the real form of H and has its singular values (each
    twice). Z, Y: M = [[Re G, -Im G], [Im G, Re G]] - t I >= 0 with G = (H + H^H) / 2
    (2n x 2n), i.e. lambda_min(G) >= t. The constants (c I, -t I) are added by the caller.
    """
    k = 4 * n if kind == "S" else 2 * n
    cols: list[FloatArray] = []
    for part in (1.0, 1j):
        for m in range(n * n):
            h = np.zeros((n, n), complex)
            h.flat[m] = part
            if kind == "S":
                e = np.block([[h.real, -h.imag], [h.imag, h.real]])
                mat = np.block([[np.zeros((2 * n, 2 * n)), e], [e.T, np.zeros((2 * n, 2 * n))]])
            else:
                g = 0.5 * (h + np.conj(h.T))
                mat = np.block([[g.real, -g.imag], [g.imag, g.real]])
            cols.append(svec(mat))
    return np.column_stack(cols), k


def _cones(
    setup: _Setup, f_hz: FloatArray, h_orig: ComplexArray, target: FloatArray
) -> list[PsdBlock]:
    """The exact passivity condition at frequencies ``f_hz`` as semidefinite blocks:
    S: sigma_max(H0 + dH) <= 1 - target; Z, Y: lambda_min of the Hermitian part of
    H0 + dH >= target * size, divided by the size (as the cuts' rows).

    A cut holds one supporting half space of this convex set, taken at the current
    model's singular (eigen-) vectors; where those vectors rotate from program to program
    the cuts creep towards the boundary and the violation returns (Kelley's method). The
    cone is the whole set: the frequency cannot be violated again."""
    n = setup.n
    t_map, k = _embedding(setup.model.kind, n)
    phi = setup.phi(f_hz)
    sizes = _sizes(setup, f_hz)
    eye = np.eye(k)
    out: list[PsdBlock] = []
    for q in range(f_hz.size):
        h = h_orig[q] / setup.h0
        z0 = np.concatenate([h.real.ravel(), h.imag.ravel()])
        # z(x) = z0 + Z x: entry m's real (imaginary) part is Re (Im) phi . x_m
        dz = sparse.vstack([
            sparse.kron(sparse.identity(n * n), phi[q].real[None, :]),
            sparse.kron(sparse.identity(n * n), phi[q].imag[None, :]),
        ], format="csr")
        lin = sparse.csr_matrix(t_map) @ dz
        if setup.model.kind == "S":
            a, b = -lin, t_map @ z0 + svec((1.0 - target[q]) * eye)
        else:
            a = -lin / sizes[q]
            b = t_map @ z0 / sizes[q] - svec(target[q] * eye)
        out.append(PsdBlock(sparse.csr_matrix(a), np.asarray(b, dtype=float), k))
    return out


def _exact_choice(setup: _Setup, new_f: FloatArray, fresh: NDArray[np.bool_],
                  hits: dict[float, int], n_cones: int) -> NDArray[np.bool_]:
    """Which of the frequencies ``new_f`` get their exact condition (:func:`_cones`)
    instead of cuts: those cut ``_CONE_AFTER`` times before and not yet exact (``fresh``),
    the most often cut first, while the cones' rows stay within ``_CONE_ROWS``; none for
    cones larger than ``_CONE_SIZE`` or programs of more than ``_CONE_UNKNOWNS``."""
    n = setup.n
    k = 4 * n if setup.model.kind == "S" else 2 * n
    small = k <= _CONE_SIZE and n * n * setup.n_b <= _CONE_UNKNOWNS
    room = max(_CONE_ROWS // (k * (k + 1) // 2) - n_cones, 0) if small else 0
    count = np.array([hits[fk] for fk in new_f])
    cand = np.flatnonzero(fresh & (count >= _CONE_AFTER))
    chosen = cand[np.argsort(-count[cand], kind="stable")][:room]
    out = np.zeros(new_f.size, dtype=bool)
    out[chosen] = True
    return out


def _sizes(setup: _Setup, f_hz: FloatArray) -> FloatArray:
    """Response size the margin is relative to: 1 (S) or ||H0(j w)||_2 floored (Z, Y)."""
    if setup.model.kind == "S":
        return np.ones(f_hz.size)
    h = _response(setup.model, f_hz) / setup.h0
    return np.maximum(np.linalg.norm(h, 2, axis=(1, 2)), setup.size_floor)


def _band_points(bands: tuple[tuple[float, float], ...], worst: float | None) -> FloatArray:
    """Cut frequencies (Hz) for violation bands: edges, interior, worst point, infinity."""
    pts: list[float] = []
    for lo, hi in bands:
        if not np.isfinite(hi):
            base = max(lo, 1e-3)
            pts += list(np.logspace(np.log10(base), np.log10(base * 1e3), 3 * _INTERIOR))
            continue
        a = lo if lo > 0 else hi * 1e-3
        count = max(_INTERIOR, int(8 * np.log10(hi / a))) + 2
        pts += list(np.logspace(np.log10(a), np.log10(hi), count))
        if lo == 0:
            pts.append(0.0)
    if worst is not None and np.isfinite(worst):
        pts.append(worst)
    return np.asarray(pts, dtype=float)


def _grid(model: RationalModel, f_data: FloatArray) -> FloatArray:
    """Dense check grid (Hz): data, log grid over the poles, resonances and 0."""
    mags = np.abs(model.poles[np.abs(model.poles) > 0]) / (2 * np.pi)
    lo, hi = (mags.min(), mags.max()) if mags.size else (1.0, 1.0)
    pos = f_data[f_data > 0]
    if pos.size:
        lo, hi = min(lo, pos.min()), max(hi, pos.max())
    parts: list[FloatArray] = [
        f_data,
        np.logspace(np.log10(lo) - 2, np.log10(hi) + 2, _GRID_LOG),
        np.zeros(1),
    ]
    for p in model.poles[model.poles.imag > 0]:
        parts.append((p.imag + abs(p.real) * np.linspace(-4, 4, 17)) / (2 * np.pi))
    g = np.unique(np.concatenate(parts))
    return np.asarray(g[g >= 0], dtype=float)


def _pick(f: FloatArray, m: FloatArray, bad: NDArray[np.bool_]) -> FloatArray:
    """Cut frequencies among the bad grid points: the local minima of the margin (the
    worst first, at most ``_MAX_NEW``), their grid neighbours and the edges of every bad
    run (the next violations of a cutting-plane iterate appear next to its cuts)."""
    idx = np.flatnonzero(bad)
    if idx.size <= _ALL_BELOW:
        return np.asarray(f[idx], dtype=float)
    left = np.concatenate([[np.inf], m[:-1]])
    right = np.concatenate([m[1:], [np.inf]])
    minima = idx[(m[idx] <= left[idx]) & (m[idx] <= right[idx])]
    minima = minima[np.argsort(m[minima])][:_MAX_NEW]
    runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    edges = np.array([r[k] for r in runs for k in (0, -1)], dtype=int)[: 2 * _MAX_NEW]
    near = (minima[:, None] + np.arange(-_NEAR, _NEAR + 1)[None, :]).ravel()
    pick = np.union1d(np.union1d(minima, edges), near[(near >= 0) & (near < f.size)])
    return np.asarray(f[pick], dtype=float)


def _weights(h_data: ComplexArray, weighting: str, h0: float) -> FloatArray:
    """Weights of the programs' objective per sample and entry: "relative" 1 / |H_ij|
    (not below 1e-3 of the sample's largest entry), else uniform 1 / ``h0``."""
    if weighting == "relative":
        mag = np.abs(h_data)
        floor = 1e-3 * np.max(mag, axis=(1, 2), keepdims=True)
        return np.asarray(1.0 / np.maximum(mag, np.maximum(floor, 1e-300)), dtype=float)
    return np.full(h_data.shape, 1.0 / h0)


def _entry_systems(
    setup_model: RationalModel,
    f: FloatArray,
    h_data: ComplexArray,
    weighting: str,
    perturb_d: bool,
    h0: float,
) -> tuple[FloatArray, list[FloatArray], list[FloatArray]]:
    """Column scale and, per entry (i, j) in row-major order, the weighted basis in its
    real form (2 n_f, n_b) and the weight per real row (the programs' objective is
    ||A_ij x_ij||^2 + ||t ||A_ij|| x_ij||^2, t = ``_TIKHONOV``)."""
    n = setup_model.n_in
    wts = _weights(h_data, weighting, h0) / np.sqrt(f.size)
    phi_d = _basis(setup_model.poles, 2j * np.pi * f, perturb_d)
    col = np.max(np.abs(phi_d), axis=0)
    col = np.where(col > 0, col, 1.0)
    phi_d = phi_d / col
    systems: list[FloatArray] = []
    weights: list[FloatArray] = []
    cache: dict[bytes, FloatArray] = {}
    for i in range(n):
        for j in range(n):
            w_ij = wts[:, i, j] * h0
            key = w_ij.tobytes()
            if key not in cache:
                a = w_ij[:, None] * phi_d
                cache[key] = np.vstack([a.real, a.imag])
            systems.append(cache[key])
            weights.append(np.concatenate([w_ij, w_ij]))
    return col, systems, weights


def _response_scale(kind: str, h_data: ComplexArray) -> float:
    """The programs' response scale: 1 for S, else the RMS of the data (1 if zero)."""
    h0 = 1.0 if kind == "S" else float(np.sqrt(np.mean(np.abs(h_data) ** 2)))
    return h0 if h0 > 0 else 1.0


def _tikhonov(a_ri: FloatArray) -> FloatArray:
    """The programs' Tikhonov rows for the weighted basis ``a_ri``: ``_TIKHONOV`` times
    its largest singular value, times the identity."""
    return np.asarray(_TIKHONOV * np.linalg.norm(a_ri, 2) * np.eye(a_ri.shape[1]), dtype=float)


def _objective(systems: list[FloatArray]) -> sparse.csr_matrix:
    """The block-diagonal QR-reduced objective (see module docstring) of the entries'
    weighted bases (:func:`_entry_systems`)."""
    blocks: list[FloatArray] = []
    cache: dict[int, FloatArray] = {}
    for a_ri in systems:
        if id(a_ri) not in cache:
            cache[id(a_ri)] = np.asarray(
                np.linalg.qr(np.vstack([a_ri, _tikhonov(a_ri)]), mode="r"), dtype=float)
        blocks.append(cache[id(a_ri)])
    return sparse.block_diag(blocks, format="csr")


def enforce(
    model: RationalModel,
    data: FrequencyData | None,
    *,
    weighting: Literal["relative", "uniform"],
    perturb_d: bool,
    max_iter: int,
    margin: float,
    keep_margin: bool = True,
    progress: Progress = no_progress,
    deadline: float | None = None,
) -> tuple[RationalModel, PassivityReport]:
    """Implementation of :func:`vfmodel.fitting.passivity.enforce_passivity`
    (``deadline``: a ``time.monotonic()`` value after which the running program stops
    and no further one starts; the first program always runs to its end)."""
    if weighting not in ("relative", "uniform"):
        raise InputError(
            "weighting: unknown choice", found=repr(weighting),
            expected="auto, relative, uniform"
        )
    if max_iter < 1:
        raise InputError("max_iter must be >= 1", found=str(max_iter))
    if not 0 < margin < 0.1:
        raise InputError("margin must be in (0, 0.1)", found=str(margin))
    first = check_passivity(model, method="hamiltonian")
    if not first.stable:
        raise PassivityError(
            "cannot enforce passivity of an unstable model (poles with Re(p) >= 0); "
            "refit with stable poles"
        )
    notes: list[str] = []
    e = model.ee
    if model.kind == "S" and np.any(e != 0):
        raise PassivityError("an S model with E != 0 cannot be bounded real; refit with E = 0")
    if model.kind != "S" and not first.e_ok:
        # nearest symmetric PSD matrix (Frobenius): clip the eigenvalues of the symmetric part
        lam, vec = np.linalg.eigh(0.5 * (e + e.T))
        e = (vec * np.clip(lam, 0, None)) @ vec.T
        notes.append("E replaced by its nearest symmetric PSD matrix")
        model = RationalModel(model.poles, model.residues, model.dd, e, model.kind, model.z0)
        first = check_passivity(model, method="hamiltonian")
    if first.passive:
        return model, first
    if model.n_poles == 0 and perturb_d:
        projected = _constant_projection(model)
        if projected is not None:
            return projected
    if not perturb_d and first.d_margin < 0:
        raise PassivityError(
            "D violates the asymptotic passivity condition and perturb_d is False"
        )

    n = model.n_in
    if data is None:
        mags = np.abs(model.poles[np.abs(model.poles) > 0])
        lo, hi = (mags.min(), mags.max()) if mags.size else (1.0, 1.0)
        f = np.logspace(np.log10(lo / 10), np.log10(hi * 10), 400) / (2 * np.pi)
        h_data = model(f)
    else:
        if not isinstance(data, FrequencyData):
            raise InputError("data must be FrequencyData", found=type(data).__name__)
        data = data.to_kind(model.kind, model.z0) if data.kind != model.kind else data
        if data.n_in != n or data.n_out != n:
            raise InputError(
                "data and model port counts differ",
                source=data.source,
                found=f"{data.n_out}x{data.n_in}",
                expected=f"{n}x{n}",
            )
        f, h_data = data.freq_hz, data.values
    h0 = _response_scale(model.kind, h_data)
    col, systems, _ = _entry_systems(model, f, h_data, weighting, perturb_d, h0)
    r_blocks = _objective(systems)

    grid = _grid(model, f)
    h_grid = _response(model, grid)
    size_floor = 1e-3 * float(np.max(np.linalg.norm(h_grid, 2, axis=(1, 2)))) / h0
    d_size = max(float(np.linalg.norm(model.dd, 2)) / h0, size_floor)
    setup = _Setup(model, perturb_d, margin, h0, col, r_blocks, size_floor, d_size)

    h_model_data = model(f)
    current = model
    a_all = np.zeros((0, n * n * setup.n_b))
    b_all = np.zeros(0)
    slack = np.zeros(0, dtype=int)  # programs in a row each cut was slack
    pool = np.zeros(0)  # every cut frequency so far (Hz)
    hits: dict[float, int] = {}
    cones: dict[float, PsdBlock] = {}  # exact conditions at frequencies cut again
    new_f = _band_points(first.bands_hz, first.worst_freq_hz)
    report = first
    scale = 1.0  # objective size of the last program (the next one's scale)
    for it in range(1, max_iter + 1):
        progress(_STAGE, it - 1, max_iter)
        pool = np.union1d(pool, new_f)
        extra = np.setdiff1d(new_f, grid)
        if it == 1 or extra.size:
            grid = np.union1d(grid, extra)
            size = _sizes(setup, grid)
        if it == 1:
            m_grid = _margins(model.kind, _response(model, grid) / h0) / size
            new_f = np.union1d(new_f, _pick(grid, m_grid, m_grid < 0))
        # frequencies cut again get a deeper cut (10x the margin each time, at most
        # _MAX_TARGET): a cutting plane at a curved boundary otherwise creeps towards it
        for fk in new_f:
            hits[fk] = hits.get(fk, -1) + 1
        target = np.array([min(margin * 10.0 ** hits[fk], _MAX_TARGET) for fk in new_f])
        target = np.maximum(target, margin)
        fresh = ~np.isin(new_f, list(cones))
        coned = _exact_choice(setup, new_f, fresh, hits, len(cones))
        cut = fresh & ~coned
        a_new, b_new = _cuts(setup, current, new_f[cut], _response(model, new_f[cut]),
                             target[cut])
        exact = _cones(setup, new_f[coned], _response(model, new_f[coned]), target[coned])
        cones.update(zip(new_f[coned], exact, strict=True))
        a_all, b_all = np.vstack([a_all, a_new]), np.concatenate([b_all, b_new])
        slack = np.concatenate([slack, np.zeros(b_new.size, dtype=int)])
        # the first program always runs to its end; a later one does not start after the
        # deadline and stops at it (Clarabel's own time limit)
        x_val = _solve(setup, a_all, b_all, scale=scale, psd=tuple(cones.values()),
                       deadline=deadline if it > 1 else None)
        if x_val is None:
            raise PassivityError(
                f"passivity not certified when the time limit passed ({it - 1} convex "
                "programs completed)"
            )
        scale = float(np.sum((setup.r_blocks @ x_val) ** 2))
        current = setup.apply(x_val)
        # drop cuts far from active (they only cost solver time); a dropped cut that
        # matters again is re-added from the grid screen below
        slack = np.where(a_all @ x_val - b_all < _DROP, 0, slack + 1)
        keep = slack < _DROP_AFTER
        a_all, b_all, slack = a_all[keep], b_all[keep], slack[keep]
        # cheap screen on the dense grid first (the Hamiltonian test certifies): new cuts
        # at the grid's violations, and again at earlier cut frequencies whose margin the
        # rotation of the eigenvectors (singular vectors) left below half the target
        m_grid = _margins(model.kind, _response(current, grid) / h0) / size
        bad = m_grid < 0
        recut = np.isin(grid, pool) & (m_grid < 0.5 * margin)
        if np.any(bad):
            new_f = np.union1d(_pick(grid, m_grid, bad), grid[recut])
            continue
        report = check_passivity(current, method="hamiltonian")
        if report.passive:
            held = (setup, pool) if keep_margin else None
            current, report = _shrink(model, current, report, f, h_data, weighting, held)
            progress(_STAGE, max_iter, max_iter)
            dh = current(f) - h_model_data
            rms = float(np.sqrt(np.mean(np.abs(dh) ** 2)))
            rel = float(np.linalg.norm(dh)) / max(float(np.linalg.norm(h_data)), 1e-300)
            final = PassivityReport(
                **{
                    **report.__dict__,
                    "iterations": it,
                    "rms_change": rms,
                    "rel_rms_change": rel,
                    "notes": tuple(notes) + report.notes,
                }
            )
            return current, final
        new_f = np.union1d(_band_points(report.bands_hz, report.worst_freq_hz), grid[recut])
    if report is first or report.passive:
        report = check_passivity(current, method="hamiltonian")
    raise PassivityError(
        f"passivity not certified after {max_iter} convex programs; last violation "
        f"{report.worst_violation:.3g} in bands {report.bands_hz[:3]} Hz; "
        "raise max_iter or the margin"
    )


def _shrink(model: RationalModel, passive: RationalModel, report: PassivityReport,
            f: FloatArray, h_data: ComplexArray, weighting: str,
            keep: tuple[_Setup, FloatArray] | None) -> tuple[RationalModel, PassivityReport]:
    """The certified model of the least error on the data among ``model + t (passive -
    model)``, t = 1 and the bisection points of the smallest certified t.

    With the poles fixed the passive models form a convex set (the largest singular value
    or the least eigenvalue of the Hermitian part is convex, resp. concave, in the
    residues and D), so every t between the smallest passive one and 1 is passive. The
    programs' change is only as fine as the solver's tolerances (about 1e-10 of the
    response, however small the violation): a fit of a lossless SMA model (AWR, 3.4e-14,
    largest singular value 1 + 1.3e-11) was enforced at 2.5e-10, its bisected fraction
    at 1.9e-11; a Murata capacitor (1.9e-15, D violating by 7e-14) 1.1e-10 -> 1.1e-13.
    Each point is certified by the Hamiltonian test; the error against the data decides
    between them (a change can also bring the model closer to the data), weighted as the
    programs' objective (:func:`_weights`).

    ``keep`` (the programs' setup and cut frequencies, Hz): a point must also keep the
    required margin at the cut frequencies (or the enforced model's there, where that is
    smaller), the documented meaning of ``enforce_passivity(margin=)``; None: the margin
    was the programs' device only and may be given back (``run_fit``'s default margin)."""
    large = model.n_in**2 * model.n_poles > _SHRINK_SIZE
    n_steps = _SHRINK_STEPS // 2 if large else _SHRINK_STEPS
    res = _SHRINK_RES_LARGE if large else _SHRINK_RES
    w = _weights(h_data, weighting, 1.0)

    def err(m: RationalModel) -> float:
        return float(np.linalg.norm(w * (m(f) - h_data)))

    def margins(m: RationalModel) -> FloatArray:
        assert keep is not None
        setup, pool = keep
        return _margins(m.kind, _response(m, pool) / setup.h0) / _sizes(setup, pool)

    need = None if keep is None else np.minimum(margins(passive), keep[0].margin)

    best, best_rep, best_err = passive, report, err(passive)
    # the smallest certified fraction: a galloping start (1/2, 1/4, 1/16, 1/256, ... while
    # certified) brackets it in one step when it is near 1 (the common case) and in a few
    # when it is 1e-12 (a lossless fit violating by rounding, a change at the programs'
    # resolution); a bracket wider than a factor _SHRINK_LOG is then halved on a log
    # scale, a narrower one linearly, until it is _SHRINK_RES of its upper end
    lo, hi, t = 0.0, 1.0, 0.5
    for _ in range(n_steps):
        cand = RationalModel(model.poles, model.residues + t * (passive.residues - model.residues),
                             model.dd + t * (passive.dd - model.dd), passive.ee, model.kind,
                             model.z0)
        rep = check_passivity(cand, method="hamiltonian")
        if not rep.passive or (need is not None and np.any(margins(cand) < need)):
            lo = t
        else:
            hi = t
            e = err(cand)
            if e < best_err:
                best, best_rep, best_err = cand, rep, e
        if hi - lo <= res * hi:
            break
        if lo == 0.0:
            if hi <= _SHRINK_LEAST:
                break
            t = max(hi * hi, _SHRINK_LEAST)
        else:
            t = float(np.sqrt(lo * hi)) if hi > _SHRINK_LOG * lo else 0.5 * (lo + hi)
    return best, best_rep


# steps of _shrink at most. With the linear bisection alone (10 steps, fractions down to
# 1e-3) lossless fits ended 57-1560x beyond their fit error: Murata GRM1555 (fit 1.9e-15)
# 1.1e-13, AlbertKumar's sample.s2p (2.1e-15) 3.2e-12; a log scale first (6 steps from
# [1e-16, 1], then 10 linear) brought them to 3.0e-15 and 2.2e-15 but spent 16 Hamiltonian
# tests on every enforcement, most of them with a fraction near 1 (mlin's run_fit: 34
# enforcements, all but one at t >= 0.99, 10.8 of 24.6 s in _shrink); the galloping start
# and the stop at _SHRINK_RES of the fraction need 8 there, small fractions 16-18
# (measured: 6.9e-7, 2e-5, 1.8e-7)
_SHRINK_STEPS = 20
_SHRINK_SIZE = 4000  # ... half of them above this many residue unknowns (ports^2 x poles)
_SHRINK_LEAST = 1e-16  # least fraction searched (below it the change is rounding)
_SHRINK_RES = 1.0 / 256  # the bracket's width relative to its upper end at the stop
# ... above _SHRINK_SIZE unknowns. The Hamiltonian test of a candidate close to passive
# costs 8-10x that of one far from it (its sampling cross-check around eigenvalues near
# the axis): with 1/256 the 8-port PDN of scripts/bench_pdn.py (94 poles, fraction near 1)
# spent 30 of its 54 s in _shrink, its last candidates violating by 2e-3-6e-4 at 7-9 s a
# test (session 37's search ended at 1.6e-2: 7 s, the whole fit 28 s)
_SHRINK_RES_LARGE = 1.0 / 16
_SHRINK_LOG = 2.0


_STAGE = "passivity enforcement (convex programs)"  # progress stage of one enforcement
_ROUNDING = 8 * np.finfo(float).eps  # relative margin of a projected constant


def _constant_projection(model: RationalModel) -> tuple[RationalModel, PassivityReport] | None:
    """A pole-free model (D alone) made passive by the nearest passive constant in the
    Frobenius norm: singular values of D clipped to 1 (S), eigenvalues of its symmetric
    part clipped to 0 (Z, Y; the antisymmetric part is lossless and kept), each a few
    rounding units inside the bound so that the certificate holds. No program and no
    margin are needed: passivity of a constant is the condition on D alone, and the
    projection is the smallest change (a tee lossless to 1e-12 moves by 1e-12, not by the
    margin). None when the certificate fails all the same."""
    d = model.dd
    if model.kind == "S":
        u, sv, vh = np.linalg.svd(d)
        d_new = (u * np.minimum(sv, 1.0 - _ROUNDING)) @ vh
    else:
        sym = 0.5 * (d + d.T)
        lam, vec = np.linalg.eigh(sym)
        top = max(float(np.max(np.abs(lam))), 1e-300)
        d_new = (d - sym) + (vec * np.maximum(lam, _ROUNDING * top)) @ vec.T
    fixed = RationalModel(model.poles, model.residues, d_new, model.ee, model.kind, model.z0)
    report = check_passivity(fixed, method="hamiltonian")
    if not report.passive:
        return None
    change = float(np.linalg.norm(d_new - d))
    rel = change / max(float(np.linalg.norm(d)), 1e-300)
    return fixed, PassivityReport(**{**report.__dict__, "iterations": 0,
                                     "rms_change": change / np.sqrt(d.size),
                                     "rel_rms_change": rel})


def _solve(setup: _Setup, a: FloatArray, b: FloatArray, scale: float = 1.0,
           psd: tuple[PsdBlock, ...] = (), deadline: float | None = None
           ) -> FloatArray | None:
    """One QP: minimise ||R x|| subject to the cuts ``a x >= b``; returns x, or None when
    ``deadline`` (``time.monotonic()``) passed before Clarabel ended.

    Clarabel directly (:mod:`vfmodel.fitting._qp`); cvxpy with the same solver only when
    that ends without a solution."""
    dc = None
    if setup.perturb_d:
        m = setup.model
        last = np.arange(setup.n_b - 1, a.shape[1], setup.n_b)
        bound = 1.0 - setup.margin if m.kind == "S" else setup.margin * setup.d_size
        dc = DConstraint(m.kind, m.dd / setup.h0, last, float(setup.col[-1]), bound)
    primal = bool(psd) or a.shape[0] > max(_PRIMAL_ROWS, _PRIMAL_TALL * a.shape[1])
    x, _ = solve_qp(setup.r_blocks, setup.n_b, a, b, dc, _PRIMAL if primal else _DIRECT,
                    scale, psd, primal, deadline)
    if x is not None:
        return x
    if deadline is not None and time.monotonic() > deadline:
        return None
    return _solve_cvxpy(setup, a, b, psd)


def _solve_cvxpy(setup: _Setup, a: FloatArray, b: FloatArray,
                 psd: tuple[PsdBlock, ...] = ()) -> FloatArray:
    """The program of :func:`_solve` through cvxpy (forms and settings of _ATTEMPTS)."""
    import cvxpy

    x = cvxpy.Variable(a.shape[1])
    resid = setup.r_blocks @ x
    cons: list[Any] = [a @ x >= b]
    for blk in psd:
        unvec = unsvec(blk.k)
        mat = cvxpy.reshape(unvec @ (blk.b - blk.a @ x), (blk.k, blk.k), order="F")
        cons.append(mat >> 0)
    if setup.perturb_d:
        # asymptotic condition, exact (a cutting plane converges slowly on the PSD cone of a
        # nearly singular D): D is the last basis column of every entry
        n, m = setup.n, setup.model
        last = np.arange(setup.n_b - 1, a.shape[1], setup.n_b)
        d_new = m.dd / setup.h0 + cvxpy.reshape(x[last], (n, n), order="C") / setup.col[-1]
        if m.kind == "S":
            cons.append(cvxpy.sigma_max(d_new) <= 1.0 - setup.margin)
        elif n == 1:
            cons.append(d_new >= setup.margin * setup.d_size)
        else:
            sym = 0.5 * (d_new + d_new.T)
            cons.append(sym - setup.margin * setup.d_size * np.eye(n) >> 0)
    statuses: list[str] = []
    problems: dict[str, Any] = {}
    for form, settings in _ATTEMPTS:
        if form not in problems:
            obj = cvxpy.sum_squares(resid) if form == "sumsq" else cvxpy.norm(resid, 2)
            problems[form] = cvxpy.Problem(cvxpy.Minimize(obj), cons)
        prob = problems[form]
        try:
            with warnings.catch_warnings():
                # cvxpy warns on inaccurate solutions; the status is checked below
                warnings.simplefilter("ignore", UserWarning)
                prob.solve(solver=cvxpy.CLARABEL, **settings)
        except cvxpy.error.SolverError as err:
            statuses.append(f"error {err}")
            continue
        statuses.append(str(prob.status))
        if prob.status == cvxpy.OPTIMAL and x.value is not None:
            return np.asarray(x.value, dtype=float)
    raise SolverError(
        f"passivity program did not end with status 'optimal' (got {statuses}); "
        f"{b.size} constraints, {a.shape[1]} unknowns"
    )
