"""Bands where a fitted network disagrees with the data beyond the noise.

Input: the noise-normalised residual of a channel (``Re`` and ``Im`` of
``log(model/measured)/sigma`` at each point, independent standard normal when the model is
right). Two statistics on sliding windows of ``w`` consecutive points, for
``w`` in ``windows``:

- *bias*: ``T_b = (sum Re r)^2 / w + (sum Im r)^2 / w``, chi-square with 2 degrees of
  freedom under the null hypothesis; it detects a small systematic deviation (far below
  the noise at one point) that keeps its sign over the window;
- *excess*: ``T_e = sum (Re r^2 + Im r^2)``, chi-square with ``2 w`` degrees of freedom; it
  detects a deviation that changes sign quickly (a shifted resonance).

Each window's p-value is multiplied by the number of windows tested in the whole problem
(Bonferroni correction over channels, positions, window sizes and both statistics), so the
reported significance is the family-wise false-alarm probability; windows below ``alpha``
are merged into bands. ``significance`` is the corrected p-value expressed as a one-sided
Gaussian z score (5 = "5 sigma").

References
----------
C. E. Bonferroni, "Teoria statistica delle classi e calcolo delle probabilita", 1936;
see e.g. Y. Hochberg, A. C. Tamhane, *Multiple Comparison Procedures*, Wiley, 1987.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from vfmodel.detective.problem import Channel, channel_slices

__all__ = ["Mismatch", "locate", "n_tests", "z_of_log_p"]

ArrF = NDArray[np.float64]
WINDOWS = (4, 8, 16, 32, 64)


@dataclass(frozen=True)
class Mismatch:
    """A band of one channel where the model disagrees with the data.

    ``significance``: Bonferroni-corrected p-value as a Gaussian z score; ``p_value`` the
    corrected p-value; ``statistic`` which test fired (``bias`` or ``excess``);
    ``i0, i1`` the point indices (inclusive) of the band.
    """

    where: str
    band_hz: tuple[float, float]
    significance: float
    p_value: float
    statistic: str
    i0: int
    i1: int


def z_of_log_p(log_p: float) -> float:
    """A (corrected) p-value given by its log as a one-sided Gaussian z score; below
    exp(-700) the asymptote ``sqrt(-2 ln p)``."""
    lp = min(log_p, 0.0)
    return float(stats.norm.isf(np.exp(lp))) if lp > -700 else float(np.sqrt(-2 * lp))


def _windows(n: int, windows: Sequence[int]) -> list[int]:
    return [w for w in windows if w <= n]


def n_tests(channels: Sequence[Channel], windows: Sequence[int] = WINDOWS) -> int:
    """Number of window tests of :func:`locate` (the Bonferroni factor)."""
    return sum(2 * (c.n - w + 1) for c in channels for w in _windows(c.n, windows))


def locate(channels: Sequence[Channel], residual: ArrF, *, alpha: float = 1e-3,
           windows: Sequence[int] = WINDOWS) -> tuple[Mismatch, ...]:
    """Significant bands of every channel (see the module docstring), most significant first."""
    m = n_tests(channels, windows)
    log_m = float(np.log(max(m, 1)))
    out: list[Mismatch] = []
    for c, sl in zip(channels, channel_slices(channels), strict=True):
        r = residual[sl]
        re, im = r[: c.n], r[c.n:]
        hits: list[tuple[int, int, float, str]] = []
        for w in _windows(c.n, windows):
            k = np.ones(w)
            sre = np.convolve(re, k, "valid")
            sim = np.convolve(im, k, "valid")
            tb = (sre**2 + sim**2) / w
            te = np.convolve(re**2 + im**2, k, "valid")
            lpb = stats.chi2.logsf(tb, 2) + log_m
            lpe = stats.chi2.logsf(te, 2 * w) + log_m
            for lp, name in ((lpb, "bias"), (lpe, "excess")):
                for i in np.flatnonzero(lp < np.log(alpha)):
                    hits.append((int(i), int(i) + w - 1, float(lp[i]), name))
        if not hits:
            continue
        hits.sort()
        # merge overlapping windows into bands; a band keeps its smallest p-value
        bands: list[tuple[int, int, float, str]] = []
        a0, a1, alp, aname = hits[0]
        for h0, h1, hlp, hname in hits[1:]:
            if h0 <= a1 + 1:
                a1 = max(a1, h1)
                if hlp < alp:
                    alp, aname = hlp, hname
            else:
                bands.append((a0, a1, alp, aname))
                a0, a1, alp, aname = h0, h1, hlp, hname
        bands.append((a0, a1, alp, aname))
        for i0, i1, lp, name in bands:
            z = z_of_log_p(lp)
            out.append(Mismatch(c.where, (float(c.freq_hz[i0]), float(c.freq_hz[i1])),
                                z, float(np.exp(lp)), name, i0, i1))
    out.sort(key=lambda mm: -mm.significance)
    return tuple(out)
