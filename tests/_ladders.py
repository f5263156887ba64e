"""Closed-form S-parameters of ladder networks (reference data of the fitting tests)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def rlc_ladder_s(f: np.ndarray, sections: Sequence[tuple[float, float, float, float]],
                 z0: float = 50.0) -> np.ndarray:
    """S (f, 2, 2) of a ladder of sections (series R, series L, shunt R, shunt C): series
    R-L, then shunt R || C (R = inf: none), from the cascaded ABCD matrix (D. M. Pozar,
    "Microwave Engineering", 4th ed., table 4.2)."""
    s = 2j * np.pi * f
    a, b, c, d = np.ones_like(s), np.zeros_like(s), np.zeros_like(s), np.ones_like(s)
    for rs, ls, rp, cp in sections:
        zs, yp = rs + s * ls, 1.0 / rp + s * cp
        a, b, c, d = a, a * zs + b, c, c * zs + d
        a, b, c, d = a + b * yp, b, c + d * yp, d
    den = a + b / z0 + c * z0 + d
    out = np.empty((f.size, 2, 2), complex)
    out[:, 0, 0] = (a + b / z0 - c * z0 - d) / den
    out[:, 0, 1] = 2 * (a * d - b * c) / den
    out[:, 1, 0] = 2 / den
    out[:, 1, 1] = (-a + b / z0 - c * z0 + d) / den
    return out
