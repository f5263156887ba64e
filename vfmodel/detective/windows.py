"""Time windows where a modelled waveform disagrees with a recording beyond the noise.

The residual ``e(t) = y_measured(t) - y_model(t)`` of a band-limited record (both filtered
to ``B`` Hz) is, when the model is right, the measurement noise, whose variance
``sigma_n^2`` follows from the H1 analysis of the same record: the non-coherent output
power ``int (1 - coh^2) G_yy df`` over the band (Bendat & Piersol, eq. 7.27). A window of
``N`` samples then holds about ``nu = 2 B N / f_s`` independent samples, and
``T = nu mean(e^2) / sigma_n^2`` is approximately chi-square with ``nu`` degrees of freedom
(a band-limited white-noise approximation). Windows are tested over every record with the
Bonferroni correction and merged into intervals; ``significance`` is the corrected p-value
as a Gaussian z score. The noise of a real bench (EMI bursts at the switching edges) is
not stationary, so windows are a location aid for channels whose spectra already show a
mismatch, not a test of their own.

References
----------
J. S. Bendat, A. G. Piersol, *Random Data*, 4th ed., Wiley, 2010, Sec. 7.2 (coherent output
power) and Sec. 8.2 (chi-square distribution of variance estimates).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from vfmodel.signals.h1 import H1Result

__all__ = ["TimeWindow", "noise_variance", "time_windows"]

ArrF = NDArray[np.float64]


@dataclass(frozen=True)
class TimeWindow:
    """An interval of a record where the residual exceeds the noise.

    ``rms_ratio``: RMS of the residual in the interval over the noise RMS.
    """

    where: str
    t_s: tuple[float, float]
    significance: float
    rms_ratio: float


def noise_variance(h1: H1Result, f_max_hz: float) -> float:
    """Non-coherent output power ``int (1 - coh^2) G_yy df`` up to ``f_max_hz`` (V^2)."""
    f = h1.freq_hz
    df = float(f[1] - f[0]) if f.size > 1 else 1.0
    sel = (f > 0) & (f <= f_max_hz)
    coh = np.nan_to_num(h1.coherence[sel, 0], nan=0.0)
    return float(np.sum((1 - np.clip(coh, 0.0, 1.0) ** 2) * h1.gyy[sel, 0]) * df)


def time_windows(records: list[tuple[str, ArrF, float, float]], *, bandwidth_hz: float,
                 window_s: float = 2e-6, alpha: float = 1e-3) -> tuple[TimeWindow, ...]:
    """Significant intervals of every residual record.

    ``records``: ``(where, residual e(t), fs, noise variance)`` per record.
    """
    tests = []
    for where, e, fs, var in records:
        n = max(round(window_s * fs), 1)
        m = e.size // n
        if m == 0 or var <= 0:
            continue
        ms = np.mean(e[: m * n].reshape(m, n) ** 2, axis=1)
        nu = max(2.0 * bandwidth_hz * n / fs, 1.0)
        tests.append((where, ms, n, fs, var, nu))
    total = sum(t[1].size for t in tests)
    if total == 0:
        return ()
    log_m = float(np.log(total))
    out: list[TimeWindow] = []
    for where, ms, n, fs, var, nu in tests:
        lp = stats.chi2.logsf(nu * ms / var, nu) + log_m
        hit = np.flatnonzero(lp < np.log(alpha))
        if hit.size == 0:
            continue
        # merge consecutive windows
        groups = np.split(hit, np.flatnonzero(np.diff(hit) > 1) + 1)
        for g in groups:
            best = float(min(lp[g].min(), 0.0))
            z = float(stats.norm.isf(np.exp(best))) if best > -700 else float(np.sqrt(-2 * best))
            rms = float(np.sqrt(np.mean(ms[g]) / var))
            out.append(TimeWindow(where, (g[0] * n / fs, (g[-1] + 1) * n / fs), z, rms))
    out.sort(key=lambda w: -w.significance)
    return tuple(out)
