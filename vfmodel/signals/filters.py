"""FFT brickwall low-pass filter (whole record) and its streaming FIR counterpart.

The reference paper removes the EMI noise above 10 MHz from oscilloscope recordings by
setting every FFT bin above the cut-off to zero and transforming back
(:func:`brickwall_filter`). That operation is circular over the whole record (the record
is treated as one period) and needs the whole record in memory.

For records that do not fit in memory, :func:`filter_blocks` applies a linear-phase
(zero-delay after compensation) Kaiser-windowed-sinc FIR low-pass by overlap-save to an
iterator of blocks. It approximates the brickwall: pass band up to ``f_cut_hz`` with ripple
and stop band from ``f_cut_hz + transition_hz`` with attenuation ``atten_db``; away from
the record ends and from the transition band the two agree to the ripple.

References
----------
J. F. Kaiser, "Nonrecursive digital filter design using the I0-sinh window function",
Proc. IEEE ISCAS, 1974. A. V. Oppenheim, R. W. Schafer, *Discrete-Time Signal Processing*,
3rd ed., Pearson, 2010, sec. 7.6 (Kaiser design formulas) and 8.7 (overlap-save).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import Any

import numpy as np
import scipy.fft as sfft
from numpy.typing import ArrayLike, NDArray
from scipy.signal import fftconvolve

from vfmodel.errors import InputError
from vfmodel.signals.checks import as_channels, check_finite, check_fs

__all__ = ["F_CUT_HZ", "brickwall_filter", "filter_blocks", "lowpass_fir"]

F_CUT_HZ = 10e6
"""The analysis band of the recordings (Hz): the reference paper filters every record to
10 MHz (EMI above it), and peaks, spectra, H1 transfers and the identification use that
band. The one constant of this cut-off; everything else refers to it."""


def _check_cut(f_cut_hz: float, fs: float) -> float:
    f = float(f_cut_hz)
    if not np.isfinite(f) or f <= 0:
        raise InputError("cut-off must be finite and > 0", place="f_cut_hz", found=repr(f_cut_hz))
    return f


def brickwall_filter(
    x: ArrayLike, fs: float, f_cut_hz: float = F_CUT_HZ, *, names: list[str] | None = None
) -> NDArray[np.float64]:
    """Zero every FFT bin above ``f_cut_hz`` and transform back (the paper's filter).

    Parameters
    ----------
    x : (n_samples,) or (n_channels, n_samples) array_like
        Real samples. The record is treated as one period (circular filter).
    fs : float
        Sample rate (Hz).
    f_cut_hz : float
        Cut-off (Hz); bins with ``f > f_cut_hz`` are set to zero, ``f <= f_cut_hz`` kept.
        A cut-off at or above ``fs/2`` returns the input unchanged.
    names : list of str, optional
        Channel names for error messages.

    Returns
    -------
    ndarray
        Filtered samples, same shape as ``x`` (float64).
    """
    fs = check_fs(fs)
    f_cut = _check_cut(f_cut_hz, fs)
    arr = np.asarray(x)
    one_d = arr.ndim == 1
    chans, nm = as_channels(arr, "x", names)
    check_finite(chans, nm, "brickwall_filter")
    n = chans.shape[1]
    spec = sfft.rfft(chans, axis=-1)
    freq = sfft.rfftfreq(n, 1.0 / fs)
    spec[:, freq > f_cut] = 0.0
    out = sfft.irfft(spec, n=n, axis=-1)
    return out[0] if one_d else out


def lowpass_fir(
    fs: float,
    f_cut_hz: float = F_CUT_HZ,
    *,
    transition_hz: float | None = None,
    atten_db: float = 80.0,
) -> NDArray[np.float64]:
    """Odd-length linear-phase Kaiser-windowed-sinc low-pass (zero phase when centred).

    Pass band ``[0, f_cut_hz]``, stop band ``[f_cut_hz + transition_hz, fs/2]``, ripple
    ``10**(-atten_db/20)`` in both. ``transition_hz`` defaults to 2 % of ``f_cut_hz``.
    Length from Kaiser's formula ``N = (A - 7.95) / (2.285 * dw) + 1``.
    """
    fs = check_fs(fs)
    f_cut = _check_cut(f_cut_hz, fs)
    tw = 0.02 * f_cut if transition_hz is None else float(transition_hz)
    if not (tw > 0 and f_cut + tw < fs / 2):
        raise InputError(
            "filter band edges must lie below the Nyquist frequency",
            place="lowpass_fir",
            found=f"f_cut {f_cut:g} Hz + transition {tw:g} Hz, fs/2 = {fs / 2:g} Hz",
        )
    a = float(atten_db)
    dw = 2 * np.pi * tw / fs
    n_taps = int(np.ceil((a - 7.95) / (2.285 * dw))) + 1
    n_taps += 1 - n_taps % 2  # odd: integer delay (n_taps - 1) / 2
    if a > 50:
        beta = 0.1102 * (a - 8.7)
    elif a >= 21:
        beta = 0.5842 * (a - 21) ** 0.4 + 0.07886 * (a - 21)
    else:
        beta = 0.0
    m = (n_taps - 1) // 2
    k = np.arange(-m, m + 1)
    fc = (f_cut + tw / 2) / fs  # ideal cut-off in the middle of the transition band
    h = 2 * fc * np.sinc(2 * fc * k) * np.kaiser(n_taps, beta)
    return h / np.sum(h)  # unit DC gain


def filter_blocks(
    blocks: Iterable[ArrayLike],
    fs: float,
    f_cut_hz: float = F_CUT_HZ,
    *,
    transition_hz: float | None = None,
    atten_db: float = 80.0,
    names: list[str] | None = None,
) -> Iterator[NDArray[np.float64]]:
    """Low-pass a long multichannel record given as blocks, with bounded memory.

    Overlap-save convolution with the centred FIR of :func:`lowpass_fir`; samples before
    the start and after the end of the record are taken as zero. The yielded blocks
    together have exactly as many samples as the input (the first yields may be shorter
    because of the filter delay, the last one is the flush), in the input's order.

    Parameters
    ----------
    blocks : iterable of (n_channels, n_block) array_like
        Consecutive pieces of the record (any lengths, e.g. slices of a numpy memmap).
    fs, f_cut_hz, transition_hz, atten_db :
        As in :func:`lowpass_fir`.
    names : list of str, optional
        Channel names for error messages.

    Yields
    ------
    ndarray (n_channels, n) float64
    """
    fs = check_fs(fs)
    h = lowpass_fir(fs, f_cut_hz, transition_hz=transition_hz, atten_db=atten_db)
    m = (h.size - 1) // 2
    hist: NDArray[np.float64] | None = None
    n_ch = -1
    skip = m  # outputs before time 0
    nm: list[str] = []
    pos = 0
    for blk in blocks:
        arr, nm_b = as_channels(np.asarray(blk), "block", names)
        if hist is None:
            n_ch, nm = arr.shape[0], nm_b
            hist = np.zeros((n_ch, 2 * m))
        elif arr.shape[0] != n_ch:
            raise InputError(
                "blocks with different channel counts",
                place=f"filter_blocks: block at sample {pos}",
                found=f"{arr.shape[0]} channels",
                expected=f"{n_ch}",
            )
        check_finite(arr, nm, f"filter_blocks: block at sample {pos}")
        pos += arr.shape[1]
        if arr.shape[1] == 0:
            continue
        buf = np.concatenate([hist, arr], axis=1)
        out = _valid_conv(buf, h)
        hist = buf[:, -2 * m :] if m > 0 else buf[:, :0]
        if skip:
            k = min(skip, out.shape[1])
            out = out[:, k:]
            skip -= k
        if out.shape[1]:
            yield out
    if hist is None:
        raise InputError("no samples", place="filter_blocks: blocks")
    # flush: m zeros after the end give the last m outputs (minus any not yet skipped)
    buf = np.concatenate([hist, np.zeros((n_ch, m))], axis=1)
    out = _valid_conv(buf, h)[:, skip:]
    if out.shape[1]:
        yield out


def _valid_conv(buf: NDArray[Any], h: NDArray[np.float64]) -> NDArray[np.float64]:
    """'valid' convolution of every row of ``buf`` with ``h`` (len(buf) - len(h) + 1)."""
    if h.size == 1:
        return np.asarray(buf * h[0], dtype=float)
    return np.asarray(fftconvolve(buf, h[None, :], mode="valid", axes=-1), dtype=float)
