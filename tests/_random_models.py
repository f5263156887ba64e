"""Random stable, non-passive rational models and an independent dense-sampling reference
for the passivity tests."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from vfmodel import RationalModel

TWO_PI = 2 * np.pi


def _poles(rng: np.random.Generator, n_real: int, n_pairs: int) -> NDArray[np.complex128]:
    real = -TWO_PI * 10 ** rng.uniform(3.5, 7.5, n_real)
    w = TWO_PI * 10 ** rng.uniform(3.5, 7.0, n_pairs)
    zeta = rng.uniform(0.02, 0.3, n_pairs)
    up = -zeta * w + 1j * w * np.sqrt(1 - zeta**2)
    pairs = np.ravel(np.column_stack([up, np.conj(up)]))
    return np.concatenate([real.astype(complex), pairs])


def _residues(
    rng: np.random.Generator, poles: NDArray[np.complex128], n: int, dirt: float
) -> NDArray[np.complex128]:
    """Residues of a mostly positive-real model plus a random non-passive part ``dirt``."""
    r = np.empty((poles.size, n, n), complex)
    k = 0
    while k < poles.size:
        p = poles[k]
        m = rng.standard_normal((n, n))
        psd = m @ m.T / n + 0.1 * np.eye(n)
        noise = rng.standard_normal((n, n)) + 1j * rng.standard_normal((n, n))
        if p.imag == 0:
            r[k] = abs(p) * (psd + dirt * noise.real)
            k += 1
        else:
            beta = rng.uniform(-1, 1) * abs(p.real) / abs(p.imag)
            a = abs(p.real) * ((1 + 1j * beta) * psd + dirt * noise)
            r[k], r[k + 1] = a, np.conj(a)
            k += 2
    return r


def ref_margin(model: RationalModel, w: NDArray[np.float64]) -> NDArray[np.float64]:
    """Independent margin: min eig of Hermitian part (Z, Y) or 1 - sigma_max (S)."""
    out = np.empty(w.size)
    for k in range(0, w.size, 20000):
        wk = w[k : k + 20000]
        # direct pole-residue sum (not RationalModel.evaluate_s), E excluded
        basis = 1.0 / (1j * wk[:, None] - model.poles[None, :])
        h = np.einsum("fp,pij->fij", basis, model.residues) + model.dd[None]
        if model.n_in == 1:
            out[k : k + 20000] = 1 - np.abs(h[:, 0, 0]) if model.kind == "S" else h[:, 0, 0].real
        elif model.kind == "S":
            gram = np.conj(h.transpose(0, 2, 1)) @ h
            out[k : k + 20000] = 1 - np.sqrt(np.linalg.eigvalsh(gram)[:, -1])
        else:
            herm = 0.5 * (h + np.conj(h.transpose(0, 2, 1)))
            out[k : k + 20000] = np.linalg.eigvalsh(herm)[:, 0]
    return out


def ref_grid(model: RationalModel, n: int = 100_000) -> NDArray[np.float64]:
    """1e5-point log grid (rad/s) over the poles +- 2 decades, plus points at resonances."""
    mag = np.abs(model.poles)
    g = [np.logspace(np.log10(mag.min()) - 2, np.log10(mag.max()) + 2, n)]
    for p in model.poles[model.poles.imag > 0]:
        g.append(p.imag + abs(p.real) * np.linspace(-5, 5, 101))
    w = np.unique(np.concatenate(g))
    return w[w > 0]


def ref_crossings(model: RationalModel, n: int = 100_000) -> NDArray[np.float64]:
    """Sign changes of the margin on the dense grid, refined with brentq (rad/s)."""
    w = ref_grid(model, n)
    m = ref_margin(model, w)
    idx = np.flatnonzero(np.sign(m[1:]) != np.sign(m[:-1]))

    def f(x: float) -> float:
        return float(ref_margin(model, np.array([x]))[0])

    return np.array([brentq(f, w[i], w[i + 1], xtol=1e-15 * w[i]) for i in idx])


def random_nonpassive(
    rng: np.random.Generator,
    kind: str,
    n: int,
    *,
    n_real: int = 2,
    n_pairs: int = 4,
    singular_d: bool = False,
) -> RationalModel:
    """A stable, non-passive n-port model of ``kind`` with finite violation bands.

    Z, Y: D = c I with c a fraction of the most negative eigenvalue of Re G(j w), so that the
    model violates positive-realness in bands and is passive at infinity (``singular_d``:
    D = 0, so D + D^T is singular). S: the response is scaled so that sigma_max peaks at
    about 1.1 with sigma_max(D) = 0.4 (``singular_d``: D has a unit singular value).
    """
    for _ in range(100):
        poles = _poles(rng, n_real, n_pairs)
        res = _residues(rng, poles, n, dirt=rng.uniform(0.2, 0.6))
        g = RationalModel(poles=poles, residues=res, kind="Z")
        w = ref_grid(g, 4000)
        if kind in ("Z", "Y"):
            m = ref_margin(g, w)
            if m.min() >= 0:
                continue
            d = np.zeros((n, n)) if singular_d else 0.6 * abs(m.min()) * np.eye(n)
            model = RationalModel(poles=poles, residues=res, d=d, kind=kind)
        else:
            q, _ = np.linalg.qr(rng.standard_normal((n, n)))
            sv = np.full(n, 0.4)
            if singular_d:
                sv[0] = 1.0
            d0 = q @ np.diag(sv) @ q.T
            h = g(w / TWO_PI)
            smax = float(np.max(np.linalg.svd(h, compute_uv=False)[:, 0]))
            # scale G so that |G| peaks near 0.8; D adds up to about 1.1 - 1.2
            scale = 0.8 / smax
            model = RationalModel(poles=poles, residues=res * scale, d=d0, kind="S", z0=50.0)
            m = ref_margin(model, w)
            if m.min() >= -0.02 or (not singular_d and m.min() < -0.5):
                continue
        if ref_margin(model, ref_grid(model, 4000)).min() < 0:
            return model
    raise RuntimeError("could not draw a non-passive model")  # pragma: no cover
