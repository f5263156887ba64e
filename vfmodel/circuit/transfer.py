"""Fast transfer functions of a compiled MNA system on many frequencies (pole-residue form).

One of the fast solvers of :mod:`vfmodel.circuit._solvers` (balancing, infinite-eigenvalue
threshold and check tolerance are defined there). For identification the bearing transfer
``U, V, W -> SN`` is needed on every FFT bin of a record up to 10 MHz (~10^4 bins) for
every trial parameter set; a dense solve per bin is too slow. The finite generalized
eigenvalues ``p_k`` of ``-G v = p C v`` (right vectors
``V``, left vectors ``W``) give

    (G + sC)^-1 = V (s I - P)^-1 M^-1 W^H + (polynomial part),   M = W^H C V,

(``P = diag(p)``; using ``M^-1 W^H`` instead of ``diag(W^H C V)^-1 W^H`` keeps the formula
exact for repeated poles, e.g. three identical phases, where LAPACK's left and right
vectors of one eigenvalue are not bi-orthogonal). With ``R_k = (Cout^T v_k)(M^-1 W^H B)_k``
the transfer is ``H(s) = sum_k R_k / (s - p_k) + D``; the constant ``D`` (the infinite
eigenvalues of an index-1 network) is taken from one direct solve far above the band and
the result is checked against direct solves inside the band.

The residues from eigenvectors lose accuracy when the eigenvector matrix is ill-conditioned
(nearly repeated poles of three similar phases, poles spread over 13 decades: on detective
networks of ``data/concealed/pmsm_winding_skin_rich`` about one form in ten failed the
check; on six of them the error against direct solves reached 1.4e-5 to 4.3e-4 of the
largest response). The eigenvalues stay accurate, so the fallback keeps the poles and fits
the residues by linear least squares to direct solves on a log grid (two samples per pole,
the classical pole-residue identification with known poles, e.g. Gustavsen & Semlyen's
residue step): on those six, 4e-8 to 8e-7 on all 5001 record bins, in 18-36 ms instead of
0.27-0.36 s for direct solves on every bin; only when that also fails the check are all
bins solved directly.

References
----------
C. B. Moler, G. W. Stewart, "An algorithm for generalized matrix eigenvalue problems",
SIAM J. Numer. Anal. 10(2), 241-256, 1973. doi:10.1137/0710024
B. Gustavsen, A. Semlyen, "Rational approximation of frequency domain responses by vector
fitting", IEEE Trans. Power Delivery 14(3), 1052-1061, 1999. doi:10.1109/61.772353
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike, NDArray

from vfmodel.circuit._solvers import (
    INF_RATIO_TRANSFER,
    TRANSFER_CHECK_TOL,
    balance_pencil,
    finite_mask,
)
from vfmodel.circuit.lowrank import LowRankTransfer
from vfmodel.circuit.mna import MnaSystem
from vfmodel.errors import CircuitError

__all__ = ["PoleResidue", "TransferMemo", "pole_residue", "transfer_on"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]


@dataclass(frozen=True)
class PoleResidue:
    """``H(s) = sum_k residues[k] / (s - poles[k]) + d`` (rad/s), shape (n_out, n_in)."""

    poles: ArrC
    residues: ArrC      # (k, n_out, n_in)
    d: ArrC             # (n_out, n_in)
    e: ArrC | None = None   # (n_out, n_in): a term ``e s`` (poles far above the band)

    def __call__(self, freq_hz: ArrayLike) -> ArrC:
        s = 2j * np.pi * np.asarray(freq_hz, dtype=float)
        out = np.empty((s.size, *self.d.shape), complex)
        res = self.residues.reshape(self.poles.size, -1)          # (k, n_out n_in)
        step = 4096
        for a in range(0, s.size, step):
            inv = 1.0 / (s[a:a + step, None] - self.poles[None, :])
            out[a:a + step] = (inv @ res).reshape(-1, *self.d.shape) + self.d[None]
            if self.e is not None:
                out[a:a + step] += s[a:a + step, None, None] * self.e[None]
        return out


_F_CHECK_HZ = (1e3, 1e5, 1e6, 1e7)   # check frequencies of the pole-residue form
_FIT_MIN_BINS = 200   # fewer bins: direct solves cost no more than the fitted form's grid


def pole_residue(mna: MnaSystem, b: ArrF, cout: ArrF, values: ArrF, *,
                 f_check_hz: ArrayLike = _F_CHECK_HZ,
                 f_inf_hz: float | tuple[float, ...] = 1e10,
                 tol: float = TRANSFER_CHECK_TOL) -> PoleResidue | None:
    """Pole-residue form of ``Cout^T (G + sC)^-1 B`` or None when it fails the check.

    Parameters
    ----------
    mna : MnaSystem
    b, cout : (N, n_in), (N, n_out)
        Input and output matrices (:meth:`MnaSystem.input_matrix`, ``output_matrix``).
    values : (n_params,)
        Element values.
    f_check_hz : frequencies where the form is compared with direct solves; the relative
        error (Frobenius, relative to the largest response norm) must stay below ``tol``.
    f_inf_hz : frequency of the direct solve that fixes ``D``; with several, each is tried
        in turn (one eigendecomposition) and the first that passes the check is kept.
    """
    pr, valid_from = _checked_form(mna, b, cout, values, f_check_hz, f_inf_hz, tol)
    fc = np.asarray(f_check_hz, dtype=float)
    return pr if pr is not None and valid_from <= float(fc.min()) else None


def _checked_form(mna: MnaSystem, b: ArrF, cout: ArrF, values: ArrF, f_check_hz: ArrayLike,
                  f_inf_hz: float | tuple[float, ...], tol: float
                  ) -> tuple[PoleResidue | None, float]:
    """The pole-residue form and the lowest check frequency from which it passes the check
    at every check frequency at and above it (``inf``: at none; with the form None)."""
    g, c = mna.matrices(values)
    gs, cs, dr, dc = balance_pencil(g, c)
    none: tuple[PoleResidue | None, float] = (None, float("inf"))
    try:
        (alpha, beta), vl, vr = sla.eig(-gs, cs, left=True, right=True,
                                        homogeneous_eigvals=True, check_finite=False)
    except (np.linalg.LinAlgError, ValueError):
        return none
    fin = finite_mask(alpha, beta, gs, cs, INF_RATIO_TRANSFER)
    if not np.any(fin):
        return none
    p = alpha[fin] / beta[fin]
    v = vr[:, fin]
    w = vl[:, fin]
    m = w.conj().T @ cs @ v
    try:
        lb = np.linalg.solve(m, w.conj().T @ (dr[:, None] * b))      # (k, n_in)
    except np.linalg.LinAlgError:
        return none
    rr = (dc[:, None] * cout).T @ v                                   # (n_out, k)
    res = rr.T[:, :, None] * lb[:, None, :]
    # D from a direct solve far above the band; the direct solves (one batch: each
    # frequency is factorised on its own, as in separate calls) also give the check values
    f_inf = np.atleast_1d(np.asarray(f_inf_hz, dtype=float))
    fc = np.sort(np.asarray(f_check_hz, dtype=float))
    direct = mna.solve(np.r_[f_inf[0], fc], b, cout, values, method="dense").h
    ref = direct[1:]
    best = none
    for k, fi in enumerate(f_inf):
        ref_inf = direct[0] if k == 0 else \
            mna.solve(fi, b, cout, values, method="dense").h[0]
        s_inf = 2j * np.pi * fi
        d = ref_inf - np.einsum("k,koi->oi", 1.0 / (s_inf - p), res)
        pr = PoleResidue(p, res, d)
        err = np.linalg.norm(pr(fc) - ref, axis=(1, 2))
        ok = np.isfinite(err) & (err <= tol * np.max(np.linalg.norm(ref, axis=(1, 2))))
        # the lowest check frequency from which every check passes
        bad = np.flatnonzero(~ok)
        valid_from = float(fc[0]) if not bad.size else \
            (float(fc[bad[-1] + 1]) if bad[-1] + 1 < fc.size else float("inf"))
        if valid_from < best[1]:
            best = (pr, valid_from)
        if valid_from <= fc[0]:
            break
    return best


_FIT_SAMPLES_PER_POLE = 2     # direct solves per kept pole of the fitted form
_FIT_POLE_SPAN = 1e3          # poles above this x the top frequency become ``d + e s``
_FIT_GRID_TOP = 30.0          # the fit grid reaches this x the top frequency


def _fitted_form(mna: MnaSystem, b: ArrF, cout: ArrF, values: ArrF, f_top_hz: float,
                 tol: float) -> PoleResidue | None:
    """Pole-residue form with the pencil's eigenvalues as poles and residues fitted by
    linear least squares to direct solves; None when it fails the check.

    Poles above ``_FIT_POLE_SPAN`` x the top angular frequency act in the band as
    ``d + e s`` (relative error below (s/p)^2 = 1e-6) and are fitted as such. The samples
    are 0 Hz and a log grid from 10 Hz to ``_FIT_GRID_TOP`` x ``f_top_hz`` with
    ``_FIT_SAMPLES_PER_POLE`` points per kept pole (+ 8); columns are normalised and the
    least-squares solve drops directions below 1e-13 of the largest (clustered poles of
    similar phases give nearly collinear columns; their sum is what the fit fixes). The
    check: direct solves at the eigenvector form's check frequencies and at ``f_top_hz``
    (not grid points) must be met to ``tol`` relative to their largest norm. The
    eigenvalues and those direct solves repeat work of :func:`_checked_form` (a few ms,
    only on this fallback path)."""
    f_check_hz = np.unique(np.r_[_F_CHECK_HZ, f_top_hz])
    g, c = mna.matrices(values)
    gs, cs, _, _ = balance_pencil(g, c)
    try:
        alpha, beta = sla.eig(-gs, cs, right=False, homogeneous_eigvals=True,
                              check_finite=False)
    except (np.linalg.LinAlgError, ValueError):
        return None
    fin = finite_mask(alpha, beta, gs, cs, INF_RATIO_TRANSFER)
    w_top = 2 * np.pi * max(f_top_hz, float(np.max(f_check_hz)))
    p = alpha[fin] / beta[fin]
    p = p[np.abs(p) < _FIT_POLE_SPAN * w_top]
    n_s = _FIT_SAMPLES_PER_POLE * p.size + 8
    fs = np.r_[0.0, np.logspace(1.0, np.log10(_FIT_GRID_TOP * w_top / (2 * np.pi)), n_s)]
    try:
        h = mna.solve(fs, b, cout, values, method="auto").h
        ref = mna.solve(f_check_hz, b, cout, values, method="dense").h
    except CircuitError:
        return None

    def basis(f: ArrF) -> ArrC:
        sf = 2j * np.pi * f
        return np.concatenate([1.0 / (sf[:, None] - p[None, :]), np.ones((f.size, 1)),
                               sf[:, None] / w_top], axis=1)

    a = basis(fs)
    norm = np.linalg.norm(a, axis=0)
    coef = np.linalg.lstsq(a / norm, h.reshape(fs.size, -1), rcond=1e-13)[0] / norm[:, None]
    shape = h.shape[1:]
    k = p.size
    pr = PoleResidue(p, coef[:k].reshape(k, *shape), coef[k].reshape(shape),
                     coef[k + 1].reshape(shape) / w_top)
    err = np.linalg.norm(pr(f_check_hz) - ref, axis=(1, 2))
    scale = np.max(np.linalg.norm(ref, axis=(1, 2)))
    return pr if bool(np.all(np.isfinite(err)) and np.all(err <= tol * scale)) else None


class TransferMemo:
    """The last :func:`transfer_on` result of a term, keyed by the element values.

    The least-squares solvers evaluate the residual at a point and then ask for the
    Jacobian at the same point, whose evaluation needs the residual again: the second
    network transfer is then taken from here (an exact repeat, same values). One entry;
    a memo of a pure function, not state that changes results."""

    def __init__(self) -> None:
        self._key: bytes = b""
        self._value: ArrC | None = None
        self.lowrank: LowRankTransfer | None = None
        """Set by a fit that moves only a few elements (:mod:`vfmodel.circuit.lowrank`):
        used for element values it applies to, on the frequencies it was made for."""

    def forget(self) -> None:
        """Drop the entry and the low-rank form (the next call solves the network)."""
        self._key, self._value, self.lowrank = b"", None, None

    def entry(self) -> tuple[bytes, ArrC] | None:
        """The memo's entry (key, value), e.g. to hand it from a worker process back."""
        return None if self._value is None else (self._key, self._value)

    def restore(self, entry: tuple[bytes, ArrC]) -> None:
        """Take over an entry of :meth:`entry` (computed by another process)."""
        self._key, self._value = entry
        if self._value.flags.writeable:
            self._value.setflags(write=False)

    def __call__(self, mna: MnaSystem, b: ArrF, cout: ArrF, values: ArrF,
                 freq_hz: ArrF) -> ArrC:
        key = np.ascontiguousarray(values, dtype=float).tobytes()
        if self._value is None or key != self._key:
            lr = self.lowrank
            if lr is not None and lr.applies(np.asarray(values, dtype=float), freq_hz):
                value = lr(np.asarray(values, dtype=float))
            else:
                value = transfer_on(mna, b, cout, values, freq_hz)
            value.setflags(write=False)        # shared with the next caller: read-only
            self._value, self._key = value, key
        return self._value


def transfer_on(mna: MnaSystem, b: ArrF, cout: ArrF, values: ArrF, freq_hz: ArrF) -> ArrC:
    """``Cout^T (G + sC)^-1 B`` on ``freq_hz``: pole-residue form (``D`` fixed at 10 GHz,
    else at 1 GHz or 100 GHz), direct solves where it fails the check (the solver
    :meth:`MnaSystem.solve` picks for the size: on the 119-unknown PMSM network and 5001
    record bins sparse LU takes 0.43 s, batched dense LU 1.67 s).

    The check is made at 1 kHz, 100 kHz, 1 MHz and 10 MHz. When it fails only below some
    of them (the form of a network with slow, nearly cancelling poles can lose accuracy
    at the lowest frequencies: measured 1.1-1.5e-5 at 1 kHz and <= 6e-7 from 100 kHz up
    on a detective network fitted to independent bench 105), or at every check frequency,
    the form with fitted residues (:func:`_fitted_form`, on more than ``_FIT_MIN_BINS``
    frequencies) is tried next; when that fails too, only the frequencies below the
    lowest passing check frequency of the eigenvector form are solved directly (all of
    them when it passes none).

    Frequencies below the lowest check frequency (a record's 0 Hz bin) are never taken
    from a form, which no check covers there: the slow, nearly cancelling poles cost most
    accuracy at 0 Hz (measured up to 2e-4 of the largest transfer on independent bench 119,
    4e-8 from 1 kHz up); they are solved directly (one solve per such frequency)."""
    f = np.asarray(freq_hz, dtype=float)
    unchecked = np.abs(f) < _F_CHECK_HZ[0]
    pr, valid_from = _checked_form(mna, b, cout, values, _F_CHECK_HZ, (1e10, 1e9, 1e11),
                                   TRANSFER_CHECK_TOL)
    if pr is not None and (valid_from <= _F_CHECK_HZ[0] or not np.any(np.abs(f) < valid_from)):
        return _form_or_direct(pr, unchecked, mna, b, cout, values, f)  # passes every check
    if f.size > _FIT_MIN_BINS:
        fitted = _fitted_form(mna, b, cout, values, float(np.max(np.abs(f))),
                              TRANSFER_CHECK_TOL)
        if fitted is not None:
            return _form_or_direct(fitted, unchecked, mna, b, cout, values, f)
    if pr is None or not np.isfinite(valid_from):
        return mna.solve(f, b, cout, values, method="auto").h
    return _form_or_direct(pr, np.abs(f) < valid_from, mna, b, cout, values, f)


def _form_or_direct(form: PoleResidue, direct: NDArray[np.bool_], mna: MnaSystem, b: ArrF,
                    cout: ArrF, values: ArrF, f: ArrF) -> ArrC:
    """``form`` on ``f``, except the frequencies ``direct``, which are solved."""
    if not np.any(direct):
        return form(f)
    out = np.empty((f.size, cout.shape[1], b.shape[1]), complex)
    out[~direct] = form(f[~direct])
    out[direct] = mna.solve(f[direct], b, cout, values, method="auto").h
    return out
