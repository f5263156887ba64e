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

from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any

import numpy as np
import scipy.linalg as sla
from numpy.typing import NDArray
from scipy.linalg import lapack as _lapack

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

_TINY = 1e-300
_EXACT_FIT = 1e-12  # weighted relative RMS error below which the data is matched exactly
_GRAM_ERROR = 1e-4  # weighted error above which the Gram sigma rows are accurate enough
# columns below which least squares call LAPACK directly (unblocked Householder QR, the
# same rounding as numpy's and scipy's wrappers here; the blocked QR of numpy's and
# scipy's OpenBLAS builds round differently, and the automatic order follows rounding)
_DIRECT_COLUMNS = 128
_RANK_TOL = 1e-13  # |R_jj| / max |R_ii| below which a scaled matrix is rank deficient


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
    pole_bounds : (lo, hi) or None
        Bounds on the magnitude of real poles (scaled): a relocated real pole outside is
        moved to the bound. A real pole far below a band that does not reach 0 Hz acts
        in the band like an integrator whose out-of-band value (at 0 Hz) is huge; far
        above, like a second D; either makes a scattering model grossly non-passive out of
        band, which enforcement can only repair by distorting the fit.
    ridge : float
        Tikhonov weight of the residue solve, relative to the column-normalised system
        (0: none). Over a narrow band D, far poles and pairs of large cancelling residues
        are nearly collinear; a tiny ridge picks the small-coefficient solution, whose
        out-of-band response stays of the size of the data (Hoerl & Kennard 1970,
        doi:10.1080/00401706.1970.10488634).
    anchors : (s_v, h_v, weight) or None
        Out-of-band anchor samples of the residue solve (common weights only): scaled
        frequencies ``s_v`` (V,) outside the band, targets ``h_v`` (V, M) (the response at
        the nearer band edge, real at s = 0) and their weight. They keep the model's
        out-of-band response of the size of the data instead of whatever the poles
        extrapolate to, at a cost in the band that the weight bounds.
    """

    s: ComplexArray
    h: ComplexArray
    w: FloatArray
    fit_d: bool
    fit_e: bool
    dc_index: int | None
    pole_bounds: tuple[float, float] | None = None
    ridge: float = 0.0
    anchors: tuple[ComplexArray, ComplexArray, float] | None = None

    @property
    def n_freq(self) -> int:
        return int(self.s.size)

    @property
    def n_resp(self) -> int:
        return int(self.h.shape[1])

    # derived arrays are computed once per problem (the fits call them in every
    # relocation; ``dataclasses.replace`` gives a new problem with its own cache)
    @cached_property
    def wh(self) -> ComplexArray:
        """Weighted responses (K, M)."""
        out: ComplexArray = self.w * self.h
        return out

    @cached_property
    def wh_norm(self) -> float:
        """||W H||_F."""
        return float(np.linalg.norm(self.wh))

    @cached_property
    def power(self) -> FloatArray:
        """sum_i |w h_i|^2 per frequency (K,)."""
        out: FloatArray = np.sum(np.abs(self.wh) ** 2, axis=1)
        return out

    @cached_property
    def w2(self) -> FloatArray:
        """Weights of the real-stacked rows (2K, Mw)."""
        out: FloatArray = np.concatenate([self.w, self.w], axis=0)
        return out

    @cached_property
    def _bases(self) -> dict[bytes, tuple[ComplexArray, ComplexArray, ComplexArray | None]]:
        """Cache of :func:`bases`."""
        return {}

    @cached_property
    def _s_all(self) -> ComplexArray:
        """The sample frequencies, then those of the anchors (common weights only)."""
        if self.w.shape[1] == 1 and self.anchors is not None:
            return np.concatenate([self.s, self.anchors[0]])
        return self.s

    @cached_property
    def _residue_rhs(self) -> tuple[FloatArray, FloatArray | None, float]:
        """Right-hand side of the residue solve (rows of the samples, then of the
        anchors), the 0 Hz value matched (or None) and the right-hand side's norm."""
        h = self.h
        h0 = None
        if self.fit_d and self.dc_index is not None:
            h0 = h[self.dc_index].real  # (M,)
            h = h - h0[None, :]
        b = _realify(h) * self.w2  # (2K, M)
        if self.w.shape[1] == 1 and self.anchors is not None:
            _, h_v, wgt = self.anchors
            if h0 is not None:
                h_v = h_v - h0[None, :]
            b = np.vstack([b, wgt * _realify(h_v)])
        return b, h0, float(np.linalg.norm(b))

    @property
    def n_extra(self) -> int:
        return int(self.fit_d) + int(self.fit_e)

    def with_out_of_band(self, ridge: float, anchor_weight: float | None) -> Problem:
        """The same problem with another ridge and anchor weight; the derived arrays that
        do not depend on them (weighted data, the bases of the pole sets seen, the
        anchors' frequencies) are shared, not computed again."""
        anchors = self.anchors
        if anchors is not None and anchor_weight is not None:
            anchors = (anchors[0], anchors[1], anchor_weight)
        out = replace(self, ridge=ridge, anchors=anchors)
        for name in ("wh", "wh_norm", "power", "w2", "_s_all"):
            if name in self.__dict__:
                out.__dict__[name] = self.__dict__[name]
        out.__dict__["_bases"] = dict(self._bases)  # its own, from the same entries
        return out


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
    return int(reps.size + np.count_nonzero(reps.imag))


def sort_reps(reps: ComplexArray) -> ComplexArray:
    """Real representatives first (by magnitude), then pairs by imaginary part."""
    reps = np.asarray(reps, dtype=complex)
    im = reps.imag
    real = np.sort(reps.real[im == 0])[::-1]
    cplx = reps[im > 0]
    out: ComplexArray = np.empty(real.size + cplx.size, dtype=complex)
    out[: real.size] = real
    out[real.size :] = cplx[np.argsort(cplx.imag)]
    return out


def reps_from_eigenvalues(z: ComplexArray, stable: bool) -> ComplexArray:
    """Representatives from the eigenvalues of a real matrix (unstable ones flipped)."""
    z = np.asarray(z, dtype=complex)
    return reps_from_parts(z.real, z.imag, stable)


def reps_from_parts(wr: FloatArray, wi: FloatArray, stable: bool) -> ComplexArray:
    """:func:`reps_from_eigenvalues` of the eigenvalues ``wr + j wi`` (LAPACK's geev
    output), without forming them."""
    mag = np.hypot(wr, wi)  # |z|, as np.abs of the complex values computes it
    is_real = np.abs(wi) <= 1e-12 * np.maximum(mag, _TINY)
    real = wr[is_real]
    upper = ~is_real & (wi > 0)
    c_re, c_im = wr[upper], wi[upper]
    if stable:
        # Flip unstable poles into the left half plane; keep a tiny damping for poles on
        # the imaginary axis so that the model stays strictly stable.
        real = -np.maximum(np.abs(real), 1e-12)
        c_re = -np.maximum(np.abs(c_re), 1e-9 * mag[upper])
    n_r = real.size
    out: ComplexArray = np.empty(n_r + c_re.size, dtype=complex)
    out.real[:n_r] = np.sort(real)[::-1]
    out.imag[:n_r] = 0.0
    order = np.argsort(c_im)
    out.real[n_r:] = c_re[order]
    out.imag[n_r:] = c_im[order]
    return out


def bound_real_poles(
    reps: ComplexArray, bounds: tuple[float, float] | None
) -> ComplexArray:
    """Real representatives with their magnitude clipped to ``bounds`` (see Problem)."""
    if bounds is None:
        return reps
    real = reps.imag == 0
    mag = np.abs(reps.real[real])
    if mag.size == 0 or (mag.min() >= bounds[0] and mag.max() <= bounds[1]):
        return reps
    out = reps.copy()
    low, high = mag < bounds[0], mag > bounds[1]
    # clipped poles are spread geometrically (coincident poles make the basis singular)
    mag[low] = bounds[0] / 1.5 ** np.arange(int(np.sum(low)))
    mag[high] = bounds[1] * 1.5 ** np.arange(int(np.sum(high)))
    out[real] = -mag + 0j
    return sort_reps(out)


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
    nr = reps.size - int(np.count_nonzero(reps.imag))
    real, cplx = reps[:nr].real, reps[nr:]
    out = np.empty((s.size, nr + 2 * cplx.size), dtype=complex)
    out[:, :nr] = 1.0 / (s[:, None] - real[None, :])
    g = 1.0 / (s[:, None] - cplx[None, :])
    gc = 1.0 / (s[:, None] - np.conj(cplx)[None, :])
    out[:, nr::2] = g + gc
    out[:, nr + 1 :: 2] = 1j * (g - gc)
    return out


def _with_extra(prob: Problem, s: ComplexArray, pf: ComplexArray) -> ComplexArray:
    if not (prob.fit_d or prob.fit_e):
        return pf
    n = pf.shape[1]
    out = np.empty((s.size, n + int(prob.fit_d) + int(prob.fit_e)), dtype=complex)
    out[:, :n] = pf
    if prob.fit_d:
        out[:, n] = 1.0
    if prob.fit_e:
        out[:, -1] = s
    return out


_BASIS_CACHE = 8  # bases of this many pole sets are kept per problem


def bases(
    prob: Problem, reps: ComplexArray
) -> tuple[ComplexArray, ComplexArray, ComplexArray | None]:
    """Partial fractions (K, N) and full basis (K, Nc) of ``reps`` at the problem's
    frequencies and the full basis at the anchor frequencies (or None), kept for the last
    few pole sets (the automatic order evaluates, prunes and ranks the same poles several
    times). The arrays must not be modified."""
    key = reps.tobytes()
    cache = prob._bases
    hit = cache.get(key)
    if hit is None:
        k = prob.n_freq
        ext = partial_fractions(prob._s_all, reps)  # samples and anchors in one pass
        pf = ext[:k]
        basis_v = None
        if ext.shape[0] > k and prob.anchors is not None:
            basis_v = _with_extra(prob, prob.anchors[0], ext[k:])
        hit = (pf, _with_extra(prob, prob.s, pf), basis_v)
        if len(cache) >= _BASIS_CACHE:
            del cache[next(iter(cache))]
        cache[key] = hit
    return hit


def full_basis(
    prob: Problem, reps: ComplexArray, pf: ComplexArray | None = None
) -> ComplexArray:
    """Partial fractions (``pf`` if given) plus the fitted D (1) and E (s) columns: (K, Nc)."""
    if pf is None:
        return bases(prob, reps)[1]
    return _with_extra(prob, prob.s, pf)


def _realify(a: ComplexArray) -> FloatArray:
    """Stack real and imaginary parts along the row axis (axis -2)."""
    out: FloatArray = np.concatenate([a.real, a.imag], axis=-2)
    return out


def evaluate(
    prob: Problem,
    coef: Coefficients,
    pf: ComplexArray | None = None,
    basis: ComplexArray | None = None,
) -> ComplexArray:
    """Model responses (K, M) at the problem's frequencies (``pf``: partial fractions,
    ``basis``: the full basis of ``coef.reps``, if already computed)."""
    if basis is None:
        basis = full_basis(prob, coef.reps, pf)
    x = [coef.c]
    if prob.fit_d:
        x.append(coef.d[:, None])
    if prob.fit_e:
        x.append(coef.e[:, None])
    out: ComplexArray = basis @ np.concatenate(x, axis=1).T
    return out


def weighted_rel_rms(prob: Problem, model: ComplexArray) -> float:
    """||W (H_model - H)||_F / ||W H||_F."""
    return frobenius(prob.w * (model - prob.h)) / max(prob.wh_norm, _TINY)


# ---------------------------------------------------------------------- solves
def _scaled_lstsq(
    a: FloatArray, b: FloatArray, ridge: float = 0.0, b_norm: float | None = None
) -> FloatArray:
    """Least squares with unit-norm column scaling (columns of zeros give zero).

    Householder QR and a triangular solve; the SVD solver (minimum-norm solution) only
    when the scaled matrix is numerically rank deficient. ``ridge`` > 0 appends the rows
    ``ridge * ||b||_F / sqrt(n_cols) * I`` (Tikhonov) to the scaled system (``b_norm``:
    ||b||_F if known).

    The factorisation is called from LAPACK directly (geqrf, orgqr, trtrs: the routines
    behind numpy.linalg.qr and scipy's solve_triangular, in the same order): their
    wrappers cost more than the factorisation itself at the sizes of small fits.
    """
    norms = np.sqrt(np.add.reduce(a * a, axis=0))  # np.linalg.norm(a, axis=0)
    norms[norms == 0] = 1.0
    n_c = a.shape[1]
    if ridge > 0 and n_c:
        mu = ridge * (float(np.linalg.norm(b)) if b_norm is None else b_norm) / np.sqrt(n_c)
        an = np.zeros((a.shape[0] + n_c, n_c), order="F")  # LAPACK's layout
        np.divide(a, norms, out=an[: a.shape[0]])
        np.fill_diagonal(an[a.shape[0] :], mu)
        b_ext = np.zeros((a.shape[0] + n_c, *b.shape[1:]))
        b_ext[: a.shape[0]] = b
        b = b_ext
    else:
        an = a / norms
    if an.shape[0] >= n_c > 0 and n_c < _DIRECT_COLUMNS:
        qr_, tau, _, info = _lapack.dgeqrf(an)
        diag = np.abs(qr_.diagonal())
        if info == 0 and diag.min() > _RANK_TOL * diag.max():
            q, _, info_q = _lapack.dorgqr(qr_[:, :n_c], tau, max(1, 64 * n_c))
            # C-ordered Q and the transposed triangular solve, as numpy and scipy lay
            # them out (the same rounding: the automatic order follows it); trtrs reads
            # only the upper triangle of R (the lower one of R^T)
            q = np.ascontiguousarray(q)
            r = np.ascontiguousarray(qr_[:n_c])
            x, info_t = _lapack.dtrtrs(r.T, q.T @ b, lower=1, trans=1)
            if info_q == 0 and info_t == 0:
                out: FloatArray = (np.asarray(x, dtype=float).T / norms).T
                return out
    elif an.shape[0] >= n_c:
        q_np, r_np = np.linalg.qr(an)
        diag = np.abs(np.diag(r_np))
        if diag.size == 0 or diag.min() > _RANK_TOL * diag.max():
            x = np.asarray(sla.solve_triangular(r_np, q_np.T @ b, check_finite=False),
                           dtype=float)
            out = (x.T / norms).T
            return out
    x = _lstsq(an, b)
    out = (x.T / norms).T
    return out


# numpy.linalg's gufuncs, called without the wrappers' checks (the same LAPACK routines
# of numpy's own library, hence the same rounding; 6-8 us less per call at these sizes),
# under the wrappers' error state: a LAPACK failure (NaN results) raises LinAlgError. A
# numpy without the private module gets the public functions.
_gufuncs: Any
try:
    from numpy.linalg import _umath_linalg as _gufuncs
except ImportError:  # pragma: no cover - numpy's layout changed
    _gufuncs = None


def _linalg_error(err: str, flag: int) -> None:
    raise np.linalg.LinAlgError(f"LAPACK did not converge ({err})")


def _lapack_errors() -> np.errstate:
    return np.errstate(call=_linalg_error, invalid="call", over="ignore", divide="ignore",
                       under="ignore")


def _eigh(a: FloatArray) -> tuple[FloatArray, FloatArray]:
    """numpy.linalg.eigh of a real symmetric matrix (lower triangle)."""
    if _gufuncs is None:  # pragma: no cover
        lam, vec = np.linalg.eigh(a)
        return lam, vec
    with _lapack_errors():
        lam, vec = _gufuncs.eigh_lo(a, signature="d->dd")
    return lam, vec


def _lstsq(a: FloatArray, b: FloatArray) -> FloatArray:
    """numpy.linalg.lstsq(a, b, rcond=None)[0] of real a (m, n), b (m,) or (m, k)."""
    m, n = a.shape
    if _gufuncs is None or m == 0 or n == 0 or b.size == 0:
        return np.asarray(np.linalg.lstsq(a, b, rcond=None)[0], dtype=float)
    b2 = b[:, None] if b.ndim == 1 else b
    with _lapack_errors():
        x = _gufuncs.lstsq(a, b2, np.finfo(float).eps * max(m, n), signature="ddd->ddid")[0]
    out: FloatArray = x[:, 0] if b.ndim == 1 else x
    return out


def singular_values(a: NDArray[np.complex128] | FloatArray) -> FloatArray:
    """numpy.linalg.svd(a, compute_uv=False) of a stack of real or complex matrices."""
    if _gufuncs is None:  # pragma: no cover
        return np.asarray(np.linalg.svd(a, compute_uv=False), dtype=np.float64)
    with _lapack_errors():
        out: FloatArray = _gufuncs.svd(a, signature="D->d" if np.iscomplexobj(a) else "d->d")
    return out


def frobenius(x: NDArray[np.complexfloating]) -> float:
    """np.linalg.norm(x) of complex x: its arithmetic, without its wrapper."""
    r = x.ravel(order="K")
    return float(np.sqrt(r.real.dot(r.real) + r.imag.dot(r.imag)))


def row_norms(x: NDArray[np.complexfloating]) -> FloatArray:
    """np.linalg.norm(x, axis=1) of complex 2-D x (its arithmetic)."""
    out: FloatArray = np.sqrt(np.add.reduce((x.conj() * x).real, axis=1))
    return out


def _batched_scaled_lstsq(a: FloatArray, b: FloatArray) -> FloatArray:
    """Batched least squares ``a[i] x[i] = b[i]`` (a: (M, R, C), b: (M, R)) via pinv."""
    norms = np.linalg.norm(a, axis=1, keepdims=True)
    norms = np.where(norms > 0, norms, 1.0)
    x = np.einsum("mcr,mr->mc", np.linalg.pinv(a / norms), b)
    out: FloatArray = x / norms[:, 0, :]
    return out


@dataclass(frozen=True)
class _ResidueSystem:
    """Weighted real least-squares system of the residues for fixed poles.

    ``a`` (2K, Nk) with common weights or (M, 2K, Nk) with a weight per response, ``b``
    (2K, M); ``keep`` the basis columns solved for (the D column is eliminated when the 0
    Hz value is matched); ``h0``, ``phi0`` the 0 Hz constraint (or None).
    """

    a: FloatArray
    b: FloatArray
    keep: list[int]
    h0: FloatArray | None
    phi0: FloatArray | None


def _residue_system(
    prob: Problem,
    reps: ComplexArray,
    pf: ComplexArray | None,
    basis: ComplexArray | None = None,
) -> _ResidueSystem:
    n = n_poles(reps)
    if basis is None:
        basis = full_basis(prob, reps, pf)  # (K, Nc)
    dc = prob.dc_index if prob.fit_d else None
    b, h0, _ = prob._residue_rhs
    phi0 = None
    if dc is not None:
        phi0 = basis[dc].real.copy()
        phi0[n] = 0.0  # the D column itself is eliminated
        basis = basis - phi0[None, :]
        basis[:, n] = 0.0
    n_c = basis.shape[1]
    k_f = prob.n_freq
    if dc is None and prob.w.shape[1] == 1:
        # the weighted real rows [Re; Im] * w, then those of the anchors, written in place
        keep = list(range(n_c))
        basis_v = None
        if prob.anchors is not None:
            hit = prob._bases.get(reps.tobytes())
            basis_v = hit[2] if hit is not None else None
            if basis_v is None:
                s_v = prob.anchors[0]
                basis_v = _with_extra(prob, s_v, partial_fractions(s_v, reps))
        n_v = 0 if basis_v is None else basis_v.shape[0]
        aw = np.empty((2 * (k_f + n_v), n_c))
        np.multiply(basis.real, prob.w, out=aw[:k_f])
        np.multiply(basis.imag, prob.w, out=aw[k_f : 2 * k_f])
        if basis_v is not None and prob.anchors is not None:
            wgt = prob.anchors[2]
            np.multiply(wgt, basis_v.real, out=aw[2 * k_f : 2 * k_f + n_v])
            np.multiply(wgt, basis_v.imag, out=aw[2 * k_f + n_v :])
        return _ResidueSystem(aw, b, keep, h0, phi0)
    a = _realify(basis)  # (2K, Nc)
    w2 = prob.w2  # (2K, Mw)
    if dc is None:
        keep = list(range(a.shape[1]))
        a_keep = a
    else:
        keep = [j for j in range(a.shape[1]) if j != n]
        a_keep = a[:, keep]
    if prob.w.shape[1] == 1:
        aw = a_keep * w2
        if prob.anchors is not None:
            s_v, _, wgt = prob.anchors
            hit = prob._bases.get(reps.tobytes())
            basis_v = hit[2] if hit is not None else None
            if basis_v is None:
                basis_v = _with_extra(prob, s_v, partial_fractions(s_v, reps))
            if phi0 is not None:
                basis_v = basis_v - phi0[None, :]
                basis_v[:, n] = 0.0
            a_v = _realify(basis_v)
            aw = np.vstack([aw, wgt * (a_v if dc is None else a_v[:, keep])])
    else:
        aw = a_keep[None, :, :] * w2.T[:, :, None]  # (M, 2K, Nk)
    return _ResidueSystem(aw, b, keep, h0, phi0)


def solve_residues(
    prob: Problem,
    reps: ComplexArray,
    pf: ComplexArray | None = None,
    basis: ComplexArray | None = None,
) -> Coefficients:
    """Coefficients (C, D, E) of every response for fixed poles, in one batched solve.

    With a 0 Hz sample and ``fit_d`` the model matches Re H(0) exactly: D is eliminated by
    the constraint ``D = H(0) - phi(0) c`` before the least-squares solve. ``pf``: the
    partial fractions of ``reps``, ``basis`` their full basis, if already computed.
    """
    n = n_poles(reps)
    sys_ = _residue_system(prob, reps, pf, basis)
    if sys_.a.ndim == 2:
        x_keep = _scaled_lstsq(sys_.a, sys_.b, prob.ridge, prob._residue_rhs[2])  # (Nk, M)
    else:
        x_keep = _batched_scaled_lstsq(sys_.a, sys_.b.T).T
    if sys_.h0 is None:
        x = x_keep
    else:
        x = np.zeros((n + prob.n_extra, prob.n_resp))
        x[sys_.keep] = x_keep
    if sys_.h0 is not None and sys_.phi0 is not None:
        phi0 = sys_.phi0
        x[n] = sys_.h0 - phi0[:n] @ x[:n] - (phi0[n + 1 :] @ x[n + 1 :] if prob.fit_e else 0.0)
    m = prob.n_resp
    d = x[n].copy() if prob.fit_d else np.zeros(m)
    e = x[n + int(prob.fit_d)].copy() if prob.fit_e else np.zeros(m)
    return Coefficients(reps=reps, c=x[:n].T.copy(), d=d, e=e)


def removal_costs(prob: Problem, reps: ComplexArray) -> FloatArray:
    """Increase of the weighted squared error ||W (H_model - H)||_F^2 when one
    representative (with its conjugate) is removed and the residues are re-solved, (n_rep,).

    For a least-squares problem ``min ||A x - b||`` removing the column group ``G`` raises
    the squared residual by ``x_G^T (S_GG)^-1 x_G`` with ``S = (A^T A)^-1`` (the
    partial-F statistic of backward elimination), summed over the responses. ``S`` comes
    from the triangular factor of the column-scaled QR. Numerically rank-deficient
    systems give 0 for the affected poles (they are redundant).
    """
    return costs_of_state(*removal_state(prob, reps), reps)


def removal_state(prob: Problem, reps: ComplexArray) -> tuple[FloatArray, FloatArray]:
    """Least-squares coefficients ``x`` (Mw, Nk, M or 1) of the residue system of ``reps``
    in column-scaled coordinates and ``S = (A^T A)^-1`` (Mw, Nk, Nk) there (the ridge
    left out): what :func:`removal_costs` ranks by and :func:`drop_representative`
    updates."""
    sys_ = _residue_system(prob, reps, None)
    a = sys_.a if sys_.a.ndim == 3 else sys_.a[None]
    b = sys_.b.T[:, :, None] if sys_.a.ndim == 3 else sys_.b[None]  # (Mw, 2K, M or 1)
    norms = np.sqrt(np.add.reduce(a * a, axis=1, keepdims=True))  # np.linalg.norm's
    norms = np.where(norms > 0, norms, 1.0)
    nk = a.shape[-1]
    with np.errstate(all="ignore"):
        rinv = None
        if a.shape[0] == 1 and a.shape[1] >= nk > 0 and nk < _DIRECT_COLUMNS:
            # common weights: LAPACK directly (geqrf, orgqr, trtri; the wrappers of
            # numpy's batched qr and solve cost more than the work at these sizes)
            qr_, tau, _, info = _lapack.dgeqrf(a[0] / norms[0])
            q2, _, info_q = _lapack.dorgqr(qr_[:, :nk], tau, max(1, 64 * nk))
            ri, info_t = _lapack.dtrtri(np.triu(qr_[:nk]), lower=0)
            if info == 0 and info_q == 0 and info_t == 0:
                rinv = ri[None]
                q = q2[None]
        if rinv is None:
            q, r = np.linalg.qr(a / norms)
            rinv = np.linalg.solve(r, np.broadcast_to(np.eye(nk), r.shape))
        x = rinv @ (np.swapaxes(q, 1, 2) @ b)  # (Mw, Nk, M or 1), scaled coordinates
        s_mat = rinv @ np.swapaxes(rinv, 1, 2)  # (Mw, Nk, Nk)
    return x, s_mat


def costs_of_state(x: FloatArray, s_mat: FloatArray, reps: ComplexArray) -> FloatArray:
    """:func:`removal_costs` from the :func:`removal_state` of ``reps``."""
    nr = reps.size - int(np.count_nonzero(reps.imag))
    n = nr + 2 * (reps.size - nr)  # the pole columns: the real ones, then pairs
    cost = np.zeros(reps.size)
    with np.errstate(all="ignore"):
        diag = np.diagonal(s_mat, axis1=1, axis2=2)  # (Mw, Nk)
        if nr:
            cost[:nr] = np.sum(x[:, :nr, :] ** 2 / diag[:, :nr, None], axis=(0, 2))
        if nr < reps.size:
            s11 = diag[:, nr:n:2, None]
            s22 = diag[:, nr + 1 : n : 2, None]
            s12 = np.diagonal(s_mat[:, nr:n:2, nr + 1 : n : 2], axis1=1, axis2=2)[:, :, None]
            x1, x2 = x[:, nr:n:2, :], x[:, nr + 1 : n : 2, :]
            det = s11 * s22 - s12**2
            quad = (s22 * x1**2 - 2 * s12 * x1 * x2 + s11 * x2**2) / det
            cost[nr:] = np.sum(quad, axis=(0, 2))
    out: FloatArray = np.where(np.isfinite(cost), np.maximum(cost, 0.0), 0.0)
    return out


def drop_representative(
    x: FloatArray, s_mat: FloatArray, reps: ComplexArray, j: int
) -> tuple[FloatArray, FloatArray, ComplexArray, FloatArray] | None:
    """Remove representative ``j`` from a :func:`removal_state` without a new
    factorisation: with ``G`` its columns and ``r`` the others, the re-solved coefficients
    are ``x_r - S_rG S_GG^-1 x_G`` and the new ``S`` the Schur complement
    ``S_rr - S_rG S_GG^-1 S_Gr`` (the inverse of the remaining Gram matrix). Returns the
    new state, the representatives left and their removal costs; None when ``S_GG`` is
    singular (then factorise anew)."""
    nr = reps.size - int(np.count_nonzero(reps.imag))
    c0 = j if j < nr else nr + 2 * (j - nr)  # its first basis column
    cols = [c0] if reps[j].imag == 0 else [c0, c0 + 1]
    keep = np.ones(x.shape[1], dtype=bool)
    keep[cols] = False
    # S_GG (Mw, g, g), g = 1 or 2, inverted in closed form
    a = s_mat[:, c0, c0]
    if len(cols) == 1:
        ok = np.isfinite(a) & (a > 0)
        inv = (1.0 / np.where(ok, a, 1.0))[:, None, None]
    else:
        b, d = s_mat[:, c0, c0 + 1], s_mat[:, c0 + 1, c0 + 1]
        det = a * d - b * b  # S is symmetric positive definite: det > 0
        ok = np.isfinite(det) & (det > 1e-12 * np.abs(a * d))
        det = np.where(ok, det, 1.0)
        adj = np.empty((a.size, 2, 2))
        adj[:, 0, 0], adj[:, 0, 1], adj[:, 1, 0], adj[:, 1, 1] = d, -b, -b, a
        inv = adj / det[:, None, None]
    if not ok.all():
        return None
    s_rg = s_mat[:, keep][:, :, cols]
    x_new = x[:, keep] - s_rg @ (inv @ x[:, cols])
    s_new = s_mat[:, keep][:, :, keep] - s_rg @ inv @ np.swapaxes(s_rg, 1, 2)
    rest = np.concatenate((reps[:j], reps[j + 1 :]))
    return x_new, s_new, rest, costs_of_state(x_new, s_new, rest)


def pole_contributions(prob: Problem, coef: Coefficients) -> FloatArray:
    """Weighted RMS contribution of every representative (pair counted together), (n_rep,).

    ``sum_k,i |w_ki (pf_k1 c_i1 + pf_k2 c_i2)|^2`` from the weighted Gram entries of the
    basis columns of each representative (no (K, N, M) intermediate).
    """
    pf = bases(prob, coef.reps)[0]  # (K, N)
    nr = coef.reps.size - int(np.count_nonzero(coef.reps.imag))
    w2t = (prob.w**2).T  # (Mw, K)
    diag = w2t @ (pf.real**2 + pf.imag**2)  # (Mw, N)
    g1, g2 = pf[:, nr::2], pf[:, nr + 1 :: 2]
    cross = w2t @ (g1.real * g2.real + g1.imag * g2.imag)  # (Mw, n_pairs)
    c = coef.c  # (M, N)
    real = np.sum(c[:, :nr] ** 2 * diag[:, :nr], axis=0)
    c1, c2 = c[:, nr::2], c[:, nr + 1 :: 2]
    pair = np.sum(
        c1**2 * diag[:, nr::2] + 2 * c1 * c2 * cross + c2**2 * diag[:, nr + 1 :: 2], axis=0
    )
    ssq = np.maximum(np.concatenate([real, pair]), 0.0)
    out: FloatArray = np.sqrt(ssq / (prob.n_freq * prob.n_resp))
    return out
