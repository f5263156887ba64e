"""Array kernels of fast relaxed vector fitting with common poles.

Notation (Gustavsen 2006; Deschrijver et al. 2008): ``K`` frequency samples ``s_k`` (scaled
by ``omega_scale`` so that the band ends at |s| = 1), ``M`` responses ``H_i`` (the entries of
the response matrix, flattened), ``N`` poles. Poles are kept as *representatives*: the real
poles first, then one pole of every conjugate pair (positive imaginary part). The real
partial-fraction basis has one column per real pole and two per pair:

    phi_1 = 1/(s - a) + 1/(s - a*),  phi_2 = j/(s - a) - j/(s - a*),

so that ``c1 phi_1 + c2 phi_2 = r/(s - a) + r*/(s - a*)`` with ``r = c1 + j c2``; together
with the state-space form ``A = [[Re a, Im a], [-Im a, Re a]]``, ``b = [2, 0]`` this gives the
real pole relocation of Gustavsen & Semlyen (1999).

References
----------
B. Gustavsen, A. Semlyen, "Rational approximation of frequency domain responses by vector
fitting", IEEE Trans. Power Delivery 14(3), 1999. doi:10.1109/61.772353

B. Gustavsen, "Improving the pole relocating properties of vector fitting", IEEE Trans.
Power Delivery 21(3), 2006. doi:10.1109/TPWRD.2005.860281

D. Deschrijver, M. Mrozowski, T. Dhaene, D. De Zutter, "Macromodeling of multiport systems
using a fast implementation of the vector fitting method", IEEE Microwave Wireless Compon.
Lett. 18(6), 2008. doi:10.1109/LMWC.2008.922585
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

_TINY = 1e-300
_EXACT_FIT = 1e-12  # weighted relative RMS error below which the data is matched exactly


@dataclass(frozen=True)
class Problem:
    """A weighted fitting problem in scaled frequency.

    Attributes
    ----------
    s : (K,) complex
        Scaled complex frequencies ``j omega / omega_scale``.
    h : (K, M) complex
        Responses (the DC sample, if any, made real: a real model is real at s = 0).
    w : (K, Mw) float
        Weights, ``Mw`` is 1 (common to all responses) or M.
    fit_d, fit_e : bool
        Fit the constant and the proportional term.
    dc_index : int or None
        Index of the 0 Hz sample whose real part the model matches exactly (with ``fit_d``).
    """

    s: ComplexArray
    h: ComplexArray
    w: FloatArray
    fit_d: bool
    fit_e: bool
    dc_index: int | None

    @property
    def n_freq(self) -> int:
        return int(self.s.size)

    @property
    def n_resp(self) -> int:
        return int(self.h.shape[1])

    @property
    def wh(self) -> ComplexArray:
        """Weighted responses (K, M)."""
        out: ComplexArray = self.w * self.h
        return out

    @property
    def n_extra(self) -> int:
        return int(self.fit_d) + int(self.fit_e)


@dataclass(frozen=True)
class Coefficients:
    """Real coefficients of a fit for the representatives ``reps``.

    ``c`` (M, N) basis coefficients, ``d`` and ``e`` (M,) (scaled frequency).
    """

    reps: ComplexArray
    c: FloatArray
    d: FloatArray
    e: FloatArray


@dataclass(frozen=True)
class IterationRecord:
    """One pole-relocation step: order, weighted relative RMS error, sigma deviation."""

    order: int
    weighted_rel_rms: float
    sigma_deviation: float


@dataclass(frozen=True)
class FixedOrderResult:
    """Result of :func:`iterate`: the best coefficients seen and the iteration history."""

    coef: Coefficients
    weighted_rel_rms: float
    n_iterations: int
    converged: bool
    history: tuple[IterationRecord, ...]


# ---------------------------------------------------------------------- poles
def n_poles(reps: ComplexArray) -> int:
    """Number of poles (each complex pole of a pair counted) of the representatives."""
    return int(np.sum(reps.imag == 0) + 2 * np.sum(reps.imag != 0))


def sort_reps(reps: ComplexArray) -> ComplexArray:
    """Real representatives first (by magnitude), then pairs by imaginary part."""
    reps = np.asarray(reps, dtype=complex)
    real = np.sort(reps[reps.imag == 0].real)[::-1]
    cplx = reps[reps.imag > 0]
    cplx = cplx[np.argsort(cplx.imag)]
    out: ComplexArray = np.concatenate([real.astype(complex), cplx])
    return out


def reps_from_eigenvalues(z: ComplexArray, stable: bool) -> ComplexArray:
    """Representatives from the eigenvalues of a real matrix (unstable ones flipped)."""
    z = np.asarray(z, dtype=complex)
    mag = np.maximum(np.abs(z), _TINY)
    is_real = np.abs(z.imag) <= 1e-12 * mag
    real = z[is_real].real
    cplx = z[~is_real & (z.imag > 0)]
    if stable:
        # Flip unstable poles into the left half plane; keep a tiny damping for poles on
        # the imaginary axis so that the model stays strictly stable.
        real = -np.maximum(np.abs(real), 1e-12)
        re = -np.maximum(np.abs(cplx.real), 1e-9 * np.abs(cplx))
        cplx = re + 1j * cplx.imag
    return sort_reps(np.concatenate([real.astype(complex), cplx]))


def starting_poles(
    n: int, w_lo: float, w_hi: float, spacing: str, damping: float = 0.01
) -> ComplexArray:
    """Starting representatives for ``n`` poles between ``w_lo`` and ``w_hi`` (scaled).

    Complex pairs ``-damping*beta +- j beta`` with ``beta`` log- or linearly spaced
    (Gustavsen & Semlyen 1999, section V); an odd ``n`` adds one real pole at ``-w_lo``.
    """
    n_pairs = n // 2
    if spacing == "lin":
        beta = np.linspace(w_lo, w_hi, n_pairs) if n_pairs > 1 else np.array([w_hi])[:n_pairs]
    else:
        beta = np.geomspace(w_lo, w_hi, n_pairs) if n_pairs > 1 else np.array([w_hi])[:n_pairs]
    cplx = -damping * beta + 1j * beta
    real = np.array([-w_lo] * (n % 2), dtype=float)
    return sort_reps(np.concatenate([real.astype(complex), cplx]))


# ---------------------------------------------------------------------- basis
def partial_fractions(s: ComplexArray, reps: ComplexArray) -> ComplexArray:
    """Complex values (K, N) of the real partial-fraction basis at ``s``."""
    nr = int(np.sum(reps.imag == 0))
    real, cplx = reps[:nr].real, reps[nr:]
    out = np.empty((s.size, nr + 2 * cplx.size), dtype=complex)
    out[:, :nr] = 1.0 / (s[:, None] - real[None, :])
    g = 1.0 / (s[:, None] - cplx[None, :])
    gc = 1.0 / (s[:, None] - np.conj(cplx)[None, :])
    out[:, nr::2] = g + gc
    out[:, nr + 1 :: 2] = 1j * (g - gc)
    return out


def full_basis(prob: Problem, reps: ComplexArray) -> ComplexArray:
    """Partial fractions plus the D (1) and E (s) columns that are fitted: (K, Nc)."""
    cols = [partial_fractions(prob.s, reps)]
    if prob.fit_d:
        cols.append(np.ones((prob.n_freq, 1), complex))
    if prob.fit_e:
        cols.append(prob.s[:, None])
    return np.concatenate(cols, axis=1)


def _realify(a: ComplexArray) -> FloatArray:
    """Stack real and imaginary parts along the row axis (axis -2)."""
    out: FloatArray = np.concatenate([a.real, a.imag], axis=-2)
    return out


def evaluate(prob: Problem, coef: Coefficients) -> ComplexArray:
    """Model responses (K, M) at the problem's frequencies."""
    basis = full_basis(prob, coef.reps)
    x = [coef.c]
    if prob.fit_d:
        x.append(coef.d[:, None])
    if prob.fit_e:
        x.append(coef.e[:, None])
    out: ComplexArray = basis @ np.concatenate(x, axis=1).T
    return out


def weighted_rel_rms(prob: Problem, model: ComplexArray) -> float:
    """||W (H_model - H)||_F / ||W H||_F."""
    num = np.linalg.norm(prob.w * (model - prob.h))
    den = max(float(np.linalg.norm(prob.wh)), _TINY)
    return float(num / den)


# ---------------------------------------------------------------------- solves
def _scaled_lstsq(a: FloatArray, b: FloatArray) -> FloatArray:
    """Least squares with unit-norm column scaling (columns of zeros give zero)."""
    norms = np.linalg.norm(a, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    x = np.linalg.lstsq(a / norms, b, rcond=None)[0]
    out: FloatArray = (x.T / norms).T
    return out


def _batched_scaled_lstsq(a: FloatArray, b: FloatArray) -> FloatArray:
    """Batched least squares ``a[i] x[i] = b[i]`` (a: (M, R, C), b: (M, R)) via pinv."""
    norms = np.linalg.norm(a, axis=1, keepdims=True)
    norms = np.where(norms > 0, norms, 1.0)
    x = np.einsum("mcr,mr->mc", np.linalg.pinv(a / norms), b)
    out: FloatArray = x / norms[:, 0, :]
    return out


def solve_residues(prob: Problem, reps: ComplexArray) -> Coefficients:
    """Coefficients (C, D, E) of every response for fixed poles, in one batched solve.

    With a 0 Hz sample and ``fit_d`` the model matches Re H(0) exactly: D is eliminated by
    the constraint ``D = H(0) - phi(0) c`` before the least-squares solve.
    """
    n = n_poles(reps)
    basis = full_basis(prob, reps)  # (K, Nc)
    h = prob.h
    dc = prob.dc_index if prob.fit_d else None
    if dc is not None:
        basis = basis.copy()
        h0 = h[dc].real  # (M,)
        phi0 = basis[dc].real.copy()
        phi0[n] = 0.0  # the D column itself is eliminated
        basis = basis - np.outer(np.ones(prob.n_freq), phi0)
        basis[:, n] = 0.0
        h = h - h0[None, :]
    a = _realify(basis)  # (2K, Nc)
    w2 = np.concatenate([prob.w, prob.w], axis=0)  # (2K, Mw)
    b = _realify(h) * w2  # (2K, M)
    keep = [j for j in range(a.shape[1]) if dc is None or j != n]
    if prob.w.shape[1] == 1:
        x_keep = _scaled_lstsq(a[:, keep] * w2, b)  # (Nk, M)
    else:
        aw = a[None, :, keep] * w2.T[:, :, None]  # (M, 2K, Nk)
        x_keep = _batched_scaled_lstsq(aw, b.T).T
    x = np.zeros((a.shape[1], prob.n_resp))
    x[keep] = x_keep
    if dc is not None:
        x[n] = h0 - phi0[:n] @ x[:n] - (phi0[n + 1 :] @ x[n + 1 :] if prob.fit_e else 0.0)
    m = prob.n_resp
    d = x[n] if prob.fit_d else np.zeros(m)
    e = x[n + int(prob.fit_d)] if prob.fit_e else np.zeros(m)
    return Coefficients(reps=reps, c=x[:n].T.copy(), d=np.asarray(d), e=np.asarray(e))


def relocate_poles(
    prob: Problem, reps: ComplexArray, stable: bool = True, precise: bool = True
) -> tuple[ComplexArray, float]:
    """One relaxed pole-relocation step with the fast QR-reduced sigma system.

    For response i the weighted real system ``[Phi_c, -H_i Phi_s] [c_i; c_s] = 0`` is
    reduced by projecting out ``range(Phi_c)`` (equivalent to keeping the lower-right block
    R22 of its QR factorisation, Deschrijver et al. 2008). The stacked R22 blocks of all
    responses plus the relaxation row ``Re sum_k sigma(s_k) = K`` (Gustavsen 2006) give the
    sigma coefficients; the new poles are the zeros of sigma, eig(A - b c_s^T / d_s).

    Returns the new representatives and max_k |sigma(s_k) - 1|.
    """
    n = n_poles(reps)
    k_f = prob.n_freq
    pf = partial_fractions(prob.s, reps)  # (K, N)
    basis_c = full_basis(prob, reps)
    basis_s = np.concatenate([pf, np.ones((k_f, 1), complex)], axis=1)  # (K, N+1)
    wgt = prob.w  # (K, Mw)
    w2 = np.concatenate([wgt, wgt], axis=0)  # (2K, Mw)
    a1 = _realify(basis_c)  # (2K, Nc)
    # -W H_i Phi_s for all responses: (M, 2K, N+1)
    a2 = -_realify(prob.wh.T[:, :, None] * basis_s[None, :, :])
    if wgt.shape[1] == 1:
        q1, _ = np.linalg.qr(a1 * w2)  # (2K, Nc)
        bq = np.matmul(np.ascontiguousarray(q1.T), a2)  # (M, Nc, N+1)
    else:
        q1, _ = np.linalg.qr(a1[None] * w2.T[:, :, None])  # (M, 2K, Nc)
        bq = np.swapaxes(q1, 1, 2) @ a2
    # Fast path (precise=False): only sum_i R22_i^T R22_i enters the stacked least squares;
    # with the projector P = I - Q1 Q1^T it equals sum_i a2_i^T a2_i - B_i^T B_i with
    # B_i = Q1^T a2_i, and sum_i a2_i^T a2_i = Re(Phi_s^H diag(sum_i |w_i H_i|^2) Phi_s).
    # It squares the condition number, so it serves the growth steps of the automatic
    # order; the final relocations use the QR-reduced rows (precise=True).
    if precise:  # R22 blocks of the QR of the projected systems, stacked
        proj = a2 - (q1 @ bq if q1.ndim == 3 else np.matmul(q1, bq))
        r22: FloatArray = np.asarray(np.linalg.qr(proj, mode="r"))
        rows = r22.reshape(-1, n + 1)
    else:
        power = np.sum(np.abs(prob.wh) ** 2, axis=1)  # (K,)
        gram = (basis_s.conj().T @ (power[:, None] * basis_s)).real
        bflat = bq.reshape(-1, n + 1)
        gram = gram - bflat.T @ bflat
        dsc = 1.0 / np.sqrt(np.maximum(np.diag(gram), _TINY))
        lam, vec = np.linalg.eigh(dsc[:, None] * gram * dsc[None, :])
        rows = (np.sqrt(np.maximum(lam, 0.0))[:, None] * vec.T) / dsc[None, :]
    # relaxation row, scaled like the data (Gustavsen 2006, eq. (9)-(10))
    scale = float(np.linalg.norm(prob.wh)) / k_f
    relax = scale * np.sum(basis_s.real, axis=0)
    a = np.vstack([rows, relax[None, :]])
    b = np.zeros(a.shape[0])
    b[-1] = scale * k_f
    x = _scaled_lstsq(a, b)
    c_s, d_s = x[:n], float(x[n])
    if not np.isfinite(d_s) or abs(d_s) < 1e-8:
        # relaxed solution degenerate: fall back to the non-relaxed system with d_s = 1
        x0 = _scaled_lstsq(rows[:, :n], -rows[:, n])
        c_s, d_s = x0, 1.0
    sigma = pf @ c_s + d_s
    deviation = float(np.max(np.abs(sigma / d_s - 1.0)))
    # zeros of sigma: eig(A - b c^T / d) in the real block form
    nr = int(np.sum(reps.imag == 0))
    a_mat = np.zeros((n, n))
    bvec = np.zeros(n)
    a_mat[np.arange(nr), np.arange(nr)] = reps[:nr].real
    bvec[:nr] = 1.0
    for j, p in enumerate(reps[nr:]):
        i = nr + 2 * j
        a_mat[i, i] = a_mat[i + 1, i + 1] = p.real
        a_mat[i, i + 1] = p.imag
        a_mat[i + 1, i] = -p.imag
        bvec[i] = 2.0
    z = np.asarray(np.linalg.eigvals(a_mat - np.outer(bvec, c_s) / d_s), dtype=complex)
    return reps_from_eigenvalues(z, stable), deviation


def iterate(
    prob: Problem,
    reps: ComplexArray,
    *,
    max_iterations: int,
    tol: float,
    stable: bool = True,
    precise: bool = True,
) -> FixedOrderResult:
    """Relocate poles until converged; return the best coefficients seen.

    Converged when the weighted relative error is at machine level, when sigma has become
    1 within ``tol`` (poles no longer move) or when the error changed by less than ``tol``
    (relative) over the last iteration after at least two iterations.
    """
    best: Coefficients | None = None
    best_err = np.inf
    history: list[IterationRecord] = []
    prev = np.inf
    converged = False
    it = it_best = 0
    for it in range(1, max_iterations + 1):
        reps, dev = relocate_poles(prob, reps, stable, precise)
        coef = solve_residues(prob, reps)
        err = weighted_rel_rms(prob, evaluate(prob, coef))
        history.append(IterationRecord(n_poles(reps), err, dev))
        if err < best_err:
            best, best_err, it_best = coef, err, it
        if it - it_best >= 3:  # no improvement in three relocations: stalled at its best
            converged = True
            break
        if dev <= tol or (it >= 2 and (err <= _EXACT_FIT or abs(prev - err) <= tol * prev)):
            converged = True
            break
        prev = err
    if best is None:  # max_iterations == 0: residues for the given poles
        best = solve_residues(prob, reps)
        best_err = weighted_rel_rms(prob, evaluate(prob, best))
    return FixedOrderResult(best, float(best_err), it, converged, tuple(history))


def pole_contributions(prob: Problem, coef: Coefficients) -> FloatArray:
    """Weighted RMS contribution of every representative (pair counted together), (n_rep,)."""
    pf = partial_fractions(prob.s, coef.reps)  # (K, N)
    nr = int(np.sum(coef.reps.imag == 0))
    out = np.empty(coef.reps.size)
    for j in range(coef.reps.size):
        cols = [j] if j < nr else [nr + 2 * (j - nr), nr + 2 * (j - nr) + 1]
        part = pf[:, cols] @ coef.c[:, cols].T  # (K, M)
        out[j] = np.sqrt(np.mean(np.abs(prob.w * part) ** 2))
    return out
