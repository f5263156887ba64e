"""Noise PSD of the measured terminal voltages, for the input-noise bias of the H1 estimate
(:func:`vfmodel.greybox.objective.bearing_term`, ``input_noise=True``).

Noise on the inputs of an H1 estimate biases it low where the input spectrum is near the
noise: ``E[H1] = H (I - G_nn G_xx^-1)`` (J. S. Bendat, A. G. Piersol, "Random Data", 4th
ed., Wiley 2010, sec. 9.2). At standstill the PWM spectrum above ~7 MHz is only a few dB
above the probe noise, so the model must carry that factor, and ``G_nn`` must be known.

Two estimates of ``G_nn``, both one-sided densities (V^2/Hz, the scaling of ``h1.gxx``)
interpolated onto the H1 frequencies:

- :func:`periodic_noise_psd` from the bins between the lines of a periodic record (every
  PWM period alike): those bins hold only noise;
- :func:`quiet_noise_psd` from the stretches of the record without switching: a record
  whose periods differ (duty-cycle jitter, a rotating machine) has no empty bins, but
  between the edges the terminal voltages are flat and what varies is noise. The record is
  cut into windows; a window's activity is its detrended power summed over the three
  phases; windows with an edge or its ringing carry orders of magnitude more than the
  noise, and the windows within ``QUIET_FACTOR`` of the quietest decile are averaged
  (Welch's method over those windows: P. D. Welch, IEEE Trans. Audio Electroacoust.
  15(2), 1967, doi:10.1109/TAU.1967.1161901).

:func:`input_noise_psd` uses the periodic estimate when the record is periodic and the
quiet-window estimate otherwise. Both the identification's standstill stage and the
detective's bearing terms (every record, rotating ones too) model the bias with it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from vfmodel.greybox.objective import PreparedRecording

ArrF = NDArray[np.float64]

QUIET_WINDOW_S = 5e-6
"""Length of the windows of :func:`quiet_noise_psd` (200 kHz resolution; the PWM edges of
an 8-20 kHz drive leave stretches of tens of microseconds without switching)."""
QUIET_FACTOR = 1.5
"""A window is quiet when its activity is within this factor of the quietest decile's (the
activity of noise alone scatters by a few per cent over a window of ~300 samples of three
phases; an edge or its ringing raises it by orders of magnitude)."""
QUIET_CONTRAST = 1e-2
"""The quietest decile's activity must be below this fraction of the busiest decile's: a
record without switching stretches (every window alike: noise only, or edges in every
window) gives no estimate rather than its signal taken for noise."""
MIN_QUIET = 8
"""Fewest quiet windows for an estimate (the average of 8 periodograms scatters by
~35 % per bin before the smoothing over ``smooth_hz``)."""


def periodic_lines(prep: PreparedRecording, max_periods: int = 64,
                   min_fraction: float = 0.9995) -> int:
    """Number ``m`` of identical periods in the record (1 if it is not periodic).

    A record of ``m`` identical periods has its spectrum on every ``m``-th FFT bin only.
    ``m`` is the largest number up to ``max_periods`` for which those bins hold at least
    ``min_fraction`` of the (filtered) terminal-voltage power above DC; the rest is noise.
    """
    pw = np.sum(np.abs(prep.x_bins[:, 1:]) ** 2, axis=0)
    k = np.arange(1, prep.x_bins.shape[1])
    tot = float(pw.sum())
    best = 1
    if tot <= 0:
        return best
    for m in range(2, max_periods + 1):
        if float(pw[k % m == 0].sum()) >= min_fraction * tot:
            best = m
    return best


def _smooth_onto(fb: ArrF, psd: ArrF, weight: ArrF, smooth_hz: float, f: ArrF) -> ArrF:
    """Weighted moving mean of ``psd`` (rows) over ``smooth_hz``, interpolated onto ``f``."""
    width = max(1, round(float(smooth_hz / (fb[1] - fb[0])))) if fb.size > 1 else 1
    ker = np.ones(width)
    num = np.stack([np.convolve(row * weight, ker, mode="same") for row in psd])
    den = np.convolve(weight, ker, mode="same")
    out = num / np.maximum(den, 1.0)
    return np.stack([np.interp(f, fb, row) for row in out])


def periodic_noise_psd(prep: PreparedRecording, smooth_hz: float = 200e3,
                       min_periods: int = 4) -> ArrF | None:
    """Noise PSD (3, n_f) on the H1 grid from the bins between the lines of a periodic
    record, or None when it is not periodic (:func:`periodic_lines` < ``min_periods``):
    their power ``2 |X_k|^2 / (fs n)`` averaged over ``smooth_hz``."""
    m = periodic_lines(prep)
    if m < min_periods:
        return None
    fb = prep.bins_hz
    k = np.arange(fb.size)
    off = ((k % m != 0) & (k > 0)).astype(float)
    pw = 2.0 * np.abs(prep.x_bins) ** 2 / (prep.fs * prep.n_samples)
    return _smooth_onto(fb, pw, off, smooth_hz, prep.h1.freq_hz)


def quiet_noise_psd(prep: PreparedRecording, smooth_hz: float = 200e3,
                    window_s: float = QUIET_WINDOW_S) -> ArrF | None:
    """Noise PSD (3, n_f) on the H1 grid from the record's windows without switching (see
    the module docstring), or None when fewer than :data:`MIN_QUIET` windows are quiet.

    Each window (``window_s``, overlapping by half, of the filtered terminal voltages) is
    detrended (least-squares line) and Hann-tapered; its periodogram is
    ``2 |FFT(x w)|^2 / (fs sum w^2)``. The taper's leakage is what a flat stretch leaves
    after the detrend, far below the noise at the frequencies the bias matters (MHz).
    """
    x = np.asarray(prep.terminals, dtype=float)
    fs = float(prep.fs)
    n_win = max(16, round(window_s * fs))
    step = n_win // 2                                      # half-overlapping (Welch)
    n_seg = (x.shape[1] - n_win) // step + 1 if x.shape[1] >= n_win else 0
    if n_seg < MIN_QUIET:
        return None
    seg = np.lib.stride_tricks.sliding_window_view(x, n_win, axis=1)[:, ::step][:, :n_seg]
    t = np.linspace(-1.0, 1.0, n_win)
    # least-squares line per window and phase (t is centred: mean and slope decouple)
    seg = seg - seg.mean(axis=-1, keepdims=True) \
        - np.einsum("psk,k->ps", seg, t)[..., None] * t / float(t @ t)
    activity = np.sum(seg**2, axis=(0, 2))                       # (n_seg,)
    floor, busy = (float(v) for v in np.quantile(activity, [0.1, 0.9]))
    quiet = activity <= QUIET_FACTOR * floor
    if not 0 < floor <= QUIET_CONTRAST * busy or int(quiet.sum()) < MIN_QUIET:
        return None
    w = np.hanning(n_win)
    spec = np.fft.rfft(seg[:, quiet] * w, axis=-1)               # (3, n_quiet, n_f)
    pw: ArrF = 2.0 * np.mean(np.abs(spec) ** 2, axis=1) / (fs * float(w @ w))
    # the detrend and the taper's main lobe take the power of the lowest two bins: the
    # value of the third is held below it (white up there; where the bias matters, the
    # input power is far above this anyway)
    pw[:, :2] = pw[:, 2:3]
    fb = np.asarray(np.fft.rfftfreq(n_win, 1.0 / fs), dtype=np.float64)
    return _smooth_onto(fb, pw, np.ones(fb.size), smooth_hz, prep.h1.freq_hz)


def input_noise_psd(prep: PreparedRecording, smooth_hz: float = 200e3,
                    min_periods: int = 4) -> ArrF | None:
    """One-sided noise PSD (3, n_f) of the filtered terminal voltages on the H1 grid (same
    density scaling as ``h1.gxx``): :func:`periodic_noise_psd` when the record is periodic,
    else :func:`quiet_noise_psd`; None when neither applies."""
    out = periodic_noise_psd(prep, smooth_hz, min_periods)
    return out if out is not None else quiet_noise_psd(prep, smooth_hz)
