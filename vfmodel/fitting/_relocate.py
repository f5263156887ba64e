"""Pole relocation of fast relaxed vector fitting: the QR-reduced (or Gram) sigma system,
the zeros of sigma as new poles, and the fixed-order iteration (notation and references:
:mod:`vfmodel.fitting._vf_core`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lapack as _lapack

from vfmodel.fitting._vf_core import (
    _DIRECT_COLUMNS,
    _EXACT_FIT,
    _GRAM_ERROR,
    _TINY,
    Coefficients,
    ComplexArray,
    FixedOrderResult,
    FloatArray,
    IterationRecord,
    Problem,
    _eigh,
    _realify,
    _scaled_lstsq,
    bases,
    bound_real_poles,
    evaluate,
    full_basis,
    n_poles,
    partial_fractions,
    reps_from_eigenvalues,
    reps_from_parts,
    solve_residues,
    weighted_rel_rms,
)


def _gram_rows(gram: FloatArray) -> FloatArray:
    """Square-root rows ``R`` with ``R^T R = gram`` (symmetric PSD, diagonally scaled)."""
    dsc = 1.0 / np.sqrt(np.maximum(gram.diagonal(), _TINY))
    scaled = dsc[:, None] * gram * dsc[None, :]
    # one reduction instead of an elementwise test: a NaN or infinite entry makes the
    # sum non-finite (|entries| <= 1 for a PSD matrix with unit diagonal; a sum that
    # overflows, from a Gram difference far from PSD, is refused the same way and the
    # caller takes the exact rows)
    if not np.isfinite(float(scaled.sum())):
        raise np.linalg.LinAlgError("non-finite Gram matrix")
    # numpy's eigh (LAPACK's dsyevd called directly rounds differently, and the automatic
    # order follows the rounding: mlin.s2p 22 -> 21 poles), without its wrapper
    lam, vec = _eigh(scaled)
    out: FloatArray = (np.sqrt(np.maximum(lam, 0.0))[:, None] * vec.T) / dsc[None, :]
    return out


def _thin_q(a: FloatArray) -> FloatArray:
    """Orthonormal basis Q (m, n) of the thin QR of ``a`` (m >= n), from LAPACK directly
    (numpy.linalg.qr's wrapper costs more than the factorisation at small sizes)."""
    n = a.shape[1]
    if a.shape[0] < n or n == 0 or n >= _DIRECT_COLUMNS:
        return np.asarray(np.linalg.qr(a)[0], dtype=float)
    qr_, tau, _, info = _lapack.dgeqrf(a)
    q, _, info_q = _lapack.dorgqr(qr_[:, :n], tau, max(1, 64 * n))
    if info != 0 or info_q != 0:
        return np.asarray(np.linalg.qr(a)[0], dtype=float)
    return np.ascontiguousarray(q, dtype=float)


def _sigma_rows_common(
    prob: Problem, basis_c: ComplexArray, basis_s: ComplexArray, precise: bool
) -> FloatArray:
    """Reduced sigma rows for weights common to all responses.

    ``Phi_c`` is the same for every response, so one QR ``W Phi_c = Q1 R1`` serves all of
    them and the projections ``(I - Q1 Q1^T) a2_i`` of all responses are two matrix
    products on the (2K, M (N+1)) block. The stacked least squares over the projected
    blocks only depends on their Gram matrix ``sum_i proj_i^T proj_i`` (a GEMM), whose
    square root gives the reduced rows.
    """
    k_f, m = prob.n_freq, prob.n_resp
    n1 = basis_s.shape[1]
    a1 = np.empty((2 * k_f, basis_c.shape[1]), order="F")  # [Re; Im] of W Phi_c
    np.multiply(basis_c.real, prob.w, out=a1[:k_f])
    np.multiply(basis_c.imag, prob.w, out=a1[k_f:])
    q1 = _thin_q(a1)  # (2K, Nc)
    prod = prob.wh[:, :, None] * basis_s[:, None, :]  # (K, M, N+1)
    a2 = np.empty((2 * k_f, m, n1))
    np.negative(prod.real, out=a2[:k_f])
    np.negative(prod.imag, out=a2[k_f:])
    a2f = a2.reshape(2 * k_f, m * n1)
    bq = q1.T @ a2f  # (Nc, M (N+1))
    if precise:
        # projected blocks formed explicitly (in place), then their Gram matrix: no
        # cancellation between sum a2^T a2 and sum B^T B when the fit is already good
        a2f -= q1 @ bq
        proj = a2.reshape(-1, n1)
        return _gram_rows(proj.T @ proj)
    # sum_i a2_i^T a2_i = Re(Phi_s^H diag(sum_i |w h_i|^2) Phi_s)
    power = prob.power  # (K,)
    gram = (basis_s.conj().T @ (power[:, None] * basis_s)).real
    bflat = bq.reshape(-1, n1)
    try:
        return _gram_rows(gram - bflat.T @ bflat)
    except np.linalg.LinAlgError:  # the squared system lost it: the exact rows
        return _sigma_rows_common(prob, basis_c, basis_s, True)


def _sigma_rows_per_response(
    prob: Problem, basis_c: ComplexArray, basis_s: ComplexArray, precise: bool
) -> FloatArray:
    """Reduced sigma rows with a weight per response (one QR of W_i Phi_c each)."""
    n1 = basis_s.shape[1]
    wgt = prob.w  # (K, M)
    w2 = np.concatenate([wgt, wgt], axis=0)  # (2K, M)
    a1 = _realify(basis_c)  # (2K, Nc)
    # -W H_i Phi_s for all responses: (M, 2K, N+1)
    a2 = -_realify(prob.wh.T[:, :, None] * basis_s[None, :, :])
    q1, _ = np.linalg.qr(a1[None] * w2.T[:, :, None])  # (M, 2K, Nc)
    bq = np.swapaxes(q1, 1, 2) @ a2
    if precise:  # R22 blocks of the QR of the projected systems, stacked
        r22: FloatArray = np.asarray(np.linalg.qr(a2 - q1 @ bq, mode="r"))
        return r22.reshape(-1, n1)
    power = prob.power  # (K,)
    gram = (basis_s.conj().T @ (power[:, None] * basis_s)).real
    bflat = bq.reshape(-1, n1)
    try:
        return _gram_rows(gram - bflat.T @ bflat)
    except np.linalg.LinAlgError:  # the squared system lost it: the exact rows
        return _sigma_rows_per_response(prob, basis_c, basis_s, True)


def relocate_poles(
    prob: Problem,
    reps: ComplexArray,
    stable: bool = True,
    precise: bool = True,
    pf: ComplexArray | None = None,
    basis: ComplexArray | None = None,
) -> tuple[ComplexArray, float]:
    """One relaxed pole-relocation step with the fast QR-reduced sigma system.

    For response i the weighted real system ``[Phi_c, -H_i Phi_s] [c_i; c_s] = 0`` is
    reduced by projecting out ``range(Phi_c)`` (equivalent to keeping the lower-right block
    R22 of its QR factorisation, Deschrijver et al. 2008). The stacked R22 blocks of all
    responses plus the relaxation row ``Re sum_k sigma(s_k) = K`` (Gustavsen 2006) give the
    sigma coefficients; the new poles are the zeros of sigma, eig(A - b c_s^T / d_s).

    ``precise=False`` replaces the reduced rows by a square root of their Gram matrix
    ``sum_i a2_i^T a2_i - B_i^T B_i`` (``B_i = Q1^T a2_i``). It squares the condition
    number, so it serves the growth steps of the automatic order; final relocations use
    the QR-reduced rows.

    Returns the new representatives and max_k |sigma(s_k) - 1|. ``pf``: the partial
    fractions of ``reps`` and ``basis`` their full basis, if already computed.
    """
    n = n_poles(reps)
    k_f = prob.n_freq
    if pf is None:
        pf = partial_fractions(prob.s, reps)  # (K, N)
    basis_c = full_basis(prob, reps, pf) if basis is None else basis
    if prob.fit_d and not prob.fit_e:  # [pf, 1]: the same columns
        basis_s = basis_c
    else:
        basis_s = np.concatenate([pf, np.ones((k_f, 1), complex)], axis=1)  # (K, N+1)
    if prob.w.shape[1] == 1:
        rows = _sigma_rows_common(prob, basis_c, basis_s, precise)
    else:
        rows = _sigma_rows_per_response(prob, basis_c, basis_s, precise)
    # relaxation row, scaled like the data (Gustavsen 2006, eq. (9)-(10))
    scale = prob.wh_norm / k_f
    relax = scale * np.sum(basis_s.real, axis=0)
    a = np.concatenate((rows, relax[None, :]))
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
    nr = reps.size - int(np.count_nonzero(reps.imag))
    a_mat, bvec = _state_form(reps, nr)
    a_mat -= np.outer(bvec, c_s) / d_s
    # np.linalg.eigvals' LAPACK routine (geev), without its wrapper
    wr, wi, _, _, info = _lapack.dgeev(a_mat, compute_vl=0, compute_vr=0)
    if info != 0:
        z = np.asarray(np.linalg.eigvals(a_mat), dtype=complex)
        return reps_from_eigenvalues(z, stable), deviation
    return reps_from_parts(wr, wi, stable), deviation


_FORMS: dict[tuple[int, int], tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp],
                                    FloatArray]] = {}


def _state_form(reps: ComplexArray, nr: int) -> tuple[FloatArray, FloatArray]:
    """Real block-diagonal A (n, n) of the representatives and the input vector b
    (1 per real pole, [2, 0] per pair; shared, not to be modified)."""
    key = (nr, reps.size - nr)
    form = _FORMS.get(key)
    if form is None:
        n = nr + 2 * key[1]
        i = nr + 2 * np.arange(key[1])
        b = np.zeros(n)
        b[:nr] = 1.0
        b[i] = 2.0
        # flat indices into A: the diagonal, the (i, i+1) and the (i+1, i) entries
        form = (np.arange(n) * (n + 1), i * n + i + 1, (i + 1) * n + i, b)
        _FORMS[key] = form
    diag, up, low, bvec = form
    n = bvec.size
    a_mat = np.zeros(n * n)
    re = np.empty(n)
    re[:nr] = reps[:nr].real
    re[nr::2] = re[nr + 1 :: 2] = reps[nr:].real
    a_mat[diag] = re
    a_mat[up] = reps[nr:].imag
    a_mat[low] = -reps[nr:].imag
    return a_mat.reshape(n, n), bvec


_DIVERGED = 2.0  # a Gram relocation this much worse than the previous error is redone exactly
_GRAM_ORDER = 100  # the exact sigma rows from this order on (see iterate)


def _step(prob: Problem, reps: ComplexArray, pf: ComplexArray, basis: ComplexArray,
          stable: bool, exact_rows: bool
          ) -> tuple[ComplexArray, ComplexArray, ComplexArray, Coefficients, float, float]:
    """One relocation of :func:`iterate` from ``reps`` (``pf``, ``basis`` their bases):
    the new representatives, their bases, residues, sigma's deviation and the error."""
    new, dev = relocate_poles(prob, reps, stable, exact_rows, pf, basis)
    new = bound_real_poles(new, prob.pole_bounds)
    pf_n, basis_n, _ = bases(prob, new)
    coef = solve_residues(prob, new, pf_n, basis_n)
    return new, pf_n, basis_n, coef, dev, weighted_rel_rms(prob, evaluate(prob, coef, pf_n,
                                                                          basis_n))


def iterate(
    prob: Problem,
    reps: ComplexArray,
    *,
    max_iterations: int,
    tol: float,
    stable: bool = True,
    precise: bool | None = True,
    patience: int = 3,
    err_hint: float = np.inf,
    target: float = 0.0,
) -> FixedOrderResult:
    """Relocate poles until converged; return the best coefficients seen.

    Converged when the weighted relative error is at machine level, when sigma has become
    1 within ``tol`` (poles no longer move), when the error changed by less than ``tol``
    (relative) over the last iteration after at least two iterations, or when ``patience``
    relocations in a row did not improve on the best error (stalled at its best).

    ``precise=None`` chooses the sigma rows per relocation from the error of the previous
    one (``err_hint`` before the first): the Gram form of :func:`relocate_poles` has an
    absolute error of about eps ||a2||^2 against a smallest eigenvalue of about
    (err ||a2||)^2, so it is used only while err^2 is far above eps (err > 1e-4). It also
    squares the condition number of the sigma system, which grows with the order: it is
    not used from :data:`_GRAM_ORDER` poles on, and a relocation with it that ends more
    than :data:`_DIVERGED` times above the previous error is done again with the exact
    rows (cascades of three lines, 2,001 points, 15 phase turns: single relocations of
    71-200 poles went from 2-5 % to 99 %; exact rows from 64 poles on instead moved
    diff_2xthru_with_connectors.s4p from 38 to 51 poles, whose enforcement then took 20
    minutes and ended 1.30x its bound).

    ``target`` > 0 (a trial that must reach that error): give up, not converged, when
    the error is above it and the last relocation gained less than half the relative
    improvement still needed.
    """
    best: Coefficients | None = None
    best_err = np.inf
    history: list[IterationRecord] = []
    prev = np.inf
    converged = False
    it = it_best = 0
    pf, basis, _ = bases(prob, reps)
    last = err_hint
    for it in range(1, max_iterations + 1):
        exact_rows = precise if precise is not None else \
            bool(last <= _GRAM_ERROR or n_poles(reps) >= _GRAM_ORDER)
        step = _step(prob, reps, pf, basis, stable, exact_rows)
        if not exact_rows and precise is None and step[-1] > _DIVERGED * last:
            # the Gram rows lost the sigma system (see above): again with the exact rows
            step = _step(prob, reps, pf, basis, stable, True)
        reps, pf, basis, coef, dev, err = step
        history.append(IterationRecord(n_poles(reps), err, dev))
        last = err
        if err < best_err:
            best, best_err, it_best = coef, err, it
        if target > 0 and err > target and it >= 2 and prev - err < 0.5 * (err - target):
            break  # improving too slowly to reach the target
        if it - it_best >= patience:  # no recent improvement: stalled at its best
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


