"""Spectral energy distribution, edge (rise/fall) times and the cut-off estimate (paper eq. 2).

References
----------
The reference paper, sec. II-C: energy above 10 MHz of the terminal voltages (Fig. 8) and
``f_co = 1 / (pi * min(t_r, t_f))`` (eq. 2). H. W. Johnson, M. Graham, *High-Speed Digital
Design*, Prentice Hall, 1993, sec. 1.1 (knee frequency of an edge).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft as sfft
from numpy.typing import ArrayLike, NDArray

from vfmodel.errors import InputError
from vfmodel.signals.checks import as_channels, check_finite, check_fs
from vfmodel.signals.filters import F_CUT_HZ

__all__ = [
    "EdgeTimes",
    "SpectralEnergy",
    "cutoff_frequency",
    "edge_times",
    "energy_fraction_above",
    "spectral_energy",
]


@dataclass(frozen=True)
class SpectralEnergy:
    """Cumulative one-sided energy distribution of each channel.

    ``cumulative[c, k]`` is the fraction of the energy of channel ``c`` at frequencies
    ``<= freq_hz[k]`` (so it rises to 1 at ``fs/2``).
    """

    freq_hz: NDArray[np.float64]
    cumulative: NDArray[np.float64]

    def fraction_above(self, f_hz: float) -> NDArray[np.float64]:
        """Fraction of the energy strictly above ``f_hz``, per channel."""
        k = int(np.searchsorted(self.freq_hz, f_hz, side="right")) - 1
        if k < 0:
            return np.ones(self.cumulative.shape[0])
        return np.asarray(1.0 - self.cumulative[:, k], dtype=float)


def spectral_energy(
    x: ArrayLike, fs: float, *, remove_mean: bool = True, names: list[str] | None = None
) -> SpectralEnergy:
    """Cumulative spectral energy distribution (Parseval, one-sided periodogram).

    Parameters
    ----------
    x : (n_samples,) or (n_channels, n_samples) array_like
    fs : float
        Sample rate (Hz).
    remove_mean : bool
        Subtract each channel's mean first, so the distribution describes the varying part
        of the signal (a PWM voltage's DC level otherwise dominates the total).

    Returns
    -------
    SpectralEnergy
    """
    fs = check_fs(fs)
    chans, nm = as_channels(np.asarray(x), "x", names)
    check_finite(chans, nm, "spectral_energy")
    if remove_mean:
        chans = chans - chans.mean(axis=1, keepdims=True)
    n = chans.shape[1]
    p = np.abs(sfft.rfft(chans, axis=-1)) ** 2
    # one-sided: every bin except DC (and Nyquist for even n) stands for two bins
    p[:, 1 : (n + 1) // 2] *= 2
    tot = p.sum(axis=1, keepdims=True)
    if np.any(tot <= 0):
        i = int(np.argmax(tot[:, 0] <= 0))
        raise InputError("channel has no energy (constant)", place=f"spectral_energy: {nm[i]!r}")
    cum = np.cumsum(p, axis=1) / tot
    return SpectralEnergy(freq_hz=sfft.rfftfreq(n, 1 / fs), cumulative=cum)


def energy_fraction_above(
    x: ArrayLike, fs: float, f_hz: float = F_CUT_HZ, *, remove_mean: bool = True
) -> NDArray[np.float64]:
    """Fraction of each channel's energy above ``f_hz`` (paper Fig. 8: ~0.3 % above 10 MHz)."""
    return spectral_energy(x, fs, remove_mean=remove_mean).fraction_above(f_hz)


@dataclass(frozen=True)
class EdgeTimes:
    """10-90 % edge times of a two-level (PWM) signal.

    ``rise_s``/``fall_s``: every complete rising/falling edge found; ``low``/``high``: the
    two levels (medians of the samples below/above mid-range); ``t_rise_s``/``t_fall_s``:
    the medians over the edges (NaN when no edge of that kind was found).
    """

    rise_s: NDArray[np.float64]
    fall_s: NDArray[np.float64]
    low: float
    high: float

    @property
    def t_rise_s(self) -> float:
        return float(np.median(self.rise_s)) if self.rise_s.size else float("nan")

    @property
    def t_fall_s(self) -> float:
        return float(np.median(self.fall_s)) if self.fall_s.size else float("nan")


def edge_times(
    x: ArrayLike,
    fs: float,
    *,
    low: float | None = None,
    high: float | None = None,
    lower_pct: float = 10.0,
    upper_pct: float = 90.0,
) -> EdgeTimes:
    """Rise and fall times (10-90 %) of every edge of a two-level signal.

    With hysteresis: a rising edge starts at the last crossing of the lower threshold before
    the signal first exceeds the upper threshold, so ringing after the edge (overshoot that
    dips back below 90 % but not below 10 %) does not create spurious edges. Crossing
    instants are linearly interpolated between samples.

    Parameters
    ----------
    x : (n_samples,) array_like
    fs : float
        Sample rate (Hz).
    low, high : float, optional
        Signal levels; default the medians of the samples below/above mid-range.
    lower_pct, upper_pct : float
        Thresholds in percent of ``high - low``.
    """
    fs = check_fs(fs)
    sig = np.asarray(x, dtype=float)
    if sig.ndim != 1:
        raise InputError("expected one channel", place="edge_times: x", found=f"shape {sig.shape}")
    check_finite(sig[None, :], ["x"], "edge_times")
    mid = 0.5 * (float(sig.min()) + float(sig.max()))
    lo = float(np.median(sig[sig < mid])) if low is None and np.any(sig < mid) else low
    hi = float(np.median(sig[sig >= mid])) if high is None else high
    if lo is None or not hi > lo:
        raise InputError("signal has no two distinct levels", place="edge_times: x")
    l1 = lo + lower_pct / 100 * (hi - lo)
    l2 = lo + upper_pct / 100 * (hi - lo)
    raw = np.where(sig > l2, 1, np.where(sig < l1, -1, 0)).astype(np.int8)
    idx = np.where(raw != 0, np.arange(sig.size), 0)
    last = np.maximum.accumulate(idx)  # index of the last classified sample (hysteresis)
    state = np.where((last > 0) | (raw[0] != 0), raw[last], 0)
    j = np.flatnonzero((state[1:] != state[:-1]) & (state[:-1] != 0)) + 1
    prev = last[j - 1]  # last sample of the opposite regime

    def cross(i: NDArray[np.intp], level: float) -> NDArray[np.float64]:
        x0, x1 = sig[i], sig[i + 1]
        return i + (level - x0) / (x1 - x0)

    up = state[j] > 0
    ju, pu = j[up], prev[up]
    jd, pd = j[~up], prev[~up]
    rise = (cross(ju - 1, l2) - cross(pu, l1)) / fs
    fall = (cross(jd - 1, l1) - cross(pd, l2)) / fs
    return EdgeTimes(rise_s=rise, fall_s=fall, low=lo, high=hi)


def cutoff_frequency(t_rise_s: float, t_fall_s: float) -> float:
    """``f_co = 1 / (pi * min(t_r, t_f))`` (paper eq. 2); 51 ns / 26 ns give 12.24 MHz."""
    t = min(float(t_rise_s), float(t_fall_s))
    if not (np.isfinite(t) and t > 0):
        raise InputError(
            "edge times must be finite and > 0",
            place="cutoff_frequency",
            found=f"t_r={t_rise_s!r}, t_f={t_fall_s!r}",
        )
    return 1.0 / (np.pi * t)


def log_noise_sigma(values: ArrayLike, floor: float = 0.0) -> float:
    """Noise level of a densely sampled spectrum: std of ``Re log H`` and of ``Im log H``.

    For a response smooth on the frequency grid, the second difference of ``log H`` (phase
    unwrapped) is noise of variance ``6 sigma^2``; the median absolute deviation
    (``sigma = 1.4826 MAD / sqrt 6``) keeps the few large differences at resonances from
    biasing it. For small noise, ``sigma`` is the relative noise per real component; the
    complex relative noise ``|dH|/|H|`` has std ``sqrt(2) sigma``. Returns at least
    ``floor``; NaN for fewer than 5 points.
    """
    lz = np.log(np.asarray(values, dtype=complex).ravel())
    if lz.size < 5:
        return float("nan")
    d2 = np.concatenate([np.diff(lz.real, 2), np.diff(np.unwrap(lz.imag), 2)])
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return max(1.4826 * mad / np.sqrt(6.0), floor)
