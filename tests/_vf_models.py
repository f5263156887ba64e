"""Known rational models (analytic truth) for the vector-fitting tests."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vfmodel import RationalModel

TWO_PI = 2 * np.pi


def known_model(
    n_ports: int, n_real: int, n_pairs: int, seed: int, kind: str = "Z", with_e: bool = True
) -> RationalModel:
    """Stable model with well separated poles in 1 kHz-10 MHz and random residues."""
    rng = np.random.default_rng(seed)
    real = -TWO_PI * np.geomspace(3e3, 3e6, n_real) if n_real else np.zeros(0)
    w = TWO_PI * np.geomspace(1e4, 5e6, n_pairs) if n_pairs else np.zeros(0)
    zeta = np.linspace(0.03, 0.2, n_pairs)
    up = -zeta * w + 1j * w * np.sqrt(1 - zeta**2)
    poles = np.concatenate([real.astype(complex), np.ravel(np.column_stack([up, up.conj()]))])
    res = np.empty((poles.size, n_ports, n_ports), complex)
    for k in range(n_real):
        a = rng.normal(size=(n_ports, n_ports))
        res[k] = (a + a.T) * abs(poles[k])
    for j in range(n_pairs):
        a = rng.normal(size=(n_ports, n_ports)) + 1j * rng.normal(size=(n_ports, n_ports))
        r = (a + a.T) * abs(up[j]) * 0.3
        res[n_real + 2 * j] = r
        res[n_real + 2 * j + 1] = r.conj()
    d = np.eye(n_ports) * 2.0 + 0.1
    e = np.eye(n_ports) * 1e-7 if with_e else None
    return RationalModel(poles=poles, residues=res, d=d, e=e, kind=kind)


def relative_pole_error(fitted: NDArray[np.complex128], truth: NDArray[np.complex128]) -> float:
    """max_k |p_fit - p_true| / |p_true| after matching each true pole to its nearest fit."""
    if fitted.size != truth.size:
        return float("inf")
    err = 0.0
    left = list(fitted)
    for p in truth:
        i = int(np.argmin([abs(q - p) for q in left]))
        err = max(err, abs(left.pop(i) - p) / abs(p))
    return err
