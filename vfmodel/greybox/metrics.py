"""Validation metrics of the grey-box model (CONTRACT section 6, reference paper Tables II-III).

Definitions (the numbers written to ``results.json``):

``mape_pct`` (impedance)
    Mean over the spectrum's frequency points of ``|(|Z_model| - |Z_meas|) / |Z_meas|| * 100``.
``coherence`` (impedance; the paper's "coherence coefficient", its ref. [22])
    The consistency of two responses to the same excitation across frequency, 0..1, 1 for
    identical shapes. Implemented as the frequency response assurance criterion (FRAC) of
    the two responses normalised point by point by ``|Z_meas|``:
    ``|sum_k a_k b_k^*|^2 / (sum_k |a_k|^2 sum_k |b_k|^2)`` with ``a_k = Z_model,k / |Z_meas,k|``
    and ``b_k = Z_meas,k / |Z_meas,k|``. The normalisation gives every frequency point the
    same weight (as in the MAPE) instead of letting the largest impedance values dominate;
    like every coherence it is insensitive to a common scale factor (the MAPE is not).
``peak`` (bearing voltage)
    ``max |u_B|`` over the record's settled window (:func:`settled_window`: from
    ``T_SKIP_S`` = 20 us after its start to ``T_END_S`` = 3 us before its end) after the
    10 MHz FFT brickwall filter, for the record and every model alike. A model computes the
    periodic response to the record's terminal voltages; a record that is not periodic
    (PWM with duty jitter, a record cut from a longer run) starts from a network state that
    the periodic response does not have, and the brickwall filter rings at the record's
    wrap-around. Both sit in the window's margins (the record fit leaves the same samples
    out, :mod:`vfmodel.greybox.record_fit`).
``abs_err_v``, ``rel_err_pct``
    ``|peak_model - peak_measured|`` and ``100 * abs_err_v / peak_measured``.
``spectral_corr``
    Pearson correlation coefficient of the amplitude spectra of measured and modelled
    bearing voltage over 0-10 MHz (the paper's "coherence coefficient of spectrum
    distribution", Table III), each spectrum estimated by Welch's method with the H1
    estimator's segmentation (Hann window, half-overlapping segments of the largest power
    of two up to an eighth of the record: 8192 samples, 23 segments for a 1-ms record at
    100 MS/s), amplitude ``sqrt(PSD)``. The paper does not say how its spectra were
    estimated. A single periodogram ``|FFT|`` of a noisy record is not a consistent
    estimate: its noise part has a relative standard deviation of 100 % in every bin
    however long the record, so at standstill (bearing-voltage SNR ~1 dB, paper section
    III) a perfect model correlates only 0.88-0.95 with the measured periodogram
    (independent benches 101-105). Averaging segments brings that noise down by the
    square root of their effective number, so the figure measures the model, not the noise.
``spectral_corr_periodogram``
    The same correlation of the single-record magnitude spectra ``|FFT(u_B)|`` (bins
    0-10 MHz), the previous definition, still reported beside it.

References
----------
W. Heylen, S. Lammens, P. Sas, *Modal Analysis Theory and Testing*, KU Leuven, 1997
(frequency response assurance criterion). R. J. Allemang, "The modal assurance criterion -
twenty years of use and abuse", Sound and Vibration 37(8), 14-23, 2003.
"""

from __future__ import annotations

import itertools

import numpy as np
import scipy.fft as sfft
from numpy.typing import ArrayLike, NDArray

from vfmodel.errors import InputError
from vfmodel.signals.filters import F_CUT_HZ, brickwall_filter

__all__ = [
    "band_mape_pct",
    "coherence_coefficient",
    "mape_pct",
    "peak_errors",
    "peak_v",
    "settled_window",
    "spectral_corr",
    "spectral_corr_periodogram",
]


def _pair(model: ArrayLike, meas: ArrayLike, what: str) -> tuple[NDArray[np.complex128],
                                                                  NDArray[np.complex128]]:
    a = np.asarray(model, dtype=complex).ravel()
    b = np.asarray(meas, dtype=complex).ravel()
    if a.shape != b.shape or a.size == 0:
        raise InputError(f"{what}: model and measurement must have the same non-zero length",
                         found=f"{a.size} and {b.size}")
    if np.any(b == 0):
        raise InputError(f"{what}: measured values must be non-zero")
    return a, b


def mape_pct(z_model: ArrayLike, z_meas: ArrayLike) -> float:
    """Mean absolute percentage error of the magnitudes (see module docstring)."""
    a, b = _pair(z_model, z_meas, "mape_pct")
    return float(np.mean(np.abs((np.abs(a) - np.abs(b)) / np.abs(b))) * 100.0)


def band_mape_pct(freq_hz: ArrayLike, z_model: ArrayLike, z_meas: ArrayLike,
                  edges_hz: ArrayLike) -> list[float | None]:
    """:func:`mape_pct` in each band ``[edges[i], edges[i+1])`` (None for an empty band)."""
    f = np.asarray(freq_hz, dtype=float).ravel()
    a, b = _pair(z_model, z_meas, "band_mape_pct")
    e = np.asarray(edges_hz, dtype=float)
    out: list[float | None] = []
    for lo, hi in itertools.pairwise(e):
        sel = (f >= lo) & ((f < hi) | ((hi == e[-1]) & (f <= hi)))
        out.append(mape_pct(a[sel], b[sel]) if np.any(sel) else None)
    return out


def coherence_coefficient(z_model: ArrayLike, z_meas: ArrayLike) -> float:
    """FRAC of the responses normalised by ``|Z_meas|`` (see module docstring), in [0, 1]."""
    a, b = _pair(z_model, z_meas, "coherence_coefficient")
    an = a / np.abs(b)
    bn = b / np.abs(b)
    den = float(np.sum(np.abs(an) ** 2) * np.sum(np.abs(bn) ** 2))
    return float(abs(np.vdot(bn, an)) ** 2 / den) if den > 0 else 0.0


def peak_v(u: ArrayLike, fs: float, *, f_cut_hz: float = F_CUT_HZ,
           filtered: bool = False) -> float:
    """``max |u|`` after the brickwall filter (``filtered=True``: ``u`` already filtered)."""
    x = np.asarray(u, dtype=float)
    if not filtered:
        x = brickwall_filter(x, fs, f_cut_hz)
    return float(np.max(np.abs(x)))


T_SKIP_S = 20e-6
"""Start of a record left out of the comparisons (see ``peak`` in the module docstring):
the free response of the initial state's fast modes (microseconds) decays within it."""
T_END_S = 3e-6
"""End of a record left out: the brickwall filter's ringing at the record's wrap-around."""


def settled_window(n: int, fs: float, *, t_skip_s: float = T_SKIP_S,
                   t_end_s: float = T_END_S) -> slice:
    """Samples of an ``n``-sample record at ``fs`` compared with a model: without the
    first ``t_skip_s`` and the last ``t_end_s``; at least the middle half of a short
    record is kept."""
    # whole samples (20 us at 100 MS/s is 2000, not ceil(2000.0000000000002))
    k0 = min(int(np.ceil(round(t_skip_s * fs, 6))), n // 4)
    k1 = max(n - int(np.ceil(round(t_end_s * fs, 6))), k0 + max(1, n // 2))
    return slice(k0, k1)


def peak_errors(peak_model: float, peak_meas: float) -> tuple[float, float]:
    """``(abs_err_v, rel_err_pct)`` of a predicted peak."""
    err = abs(peak_model - peak_meas)
    return float(err), float(100.0 * err / peak_meas) if peak_meas > 0 else float("inf")


PLATEAU_F_HZ = 200e3
"""Upper frequency of the plateau metric: below it the bearing voltage is the capacitive
divider's step after each edge and the film's level between edges; above it the ringing."""


def plateau_rel_err_pct(u_model: ArrayLike, u_meas: ArrayLike, fs: float, *,
                        f_max_hz: float = PLATEAU_F_HZ,
                        window: slice | None = None) -> float:
    """Relative RMS error (%) of the bearing voltage below ``f_max_hz`` (brickwall):
    ``100 ||lp(u_model) - lp(u_meas)|| / ||lp(u_meas)||`` without the mean (DC offset of
    the probe). This is the plateau after each switching edge (the bearing-voltage ratio of
    the capacitive divider) and the level between edges, without the ringing. ``window``:
    the samples compared (default all; the whole records are filtered)."""
    w = slice(None) if window is None else window
    a = brickwall_filter(np.asarray(u_model, dtype=float), fs, f_max_hz)[w]
    b = brickwall_filter(np.asarray(u_meas, dtype=float), fs, f_max_hz)[w]
    a = a - a.mean()
    b = b - b.mean()
    nb = float(np.linalg.norm(b))
    return float(100.0 * np.linalg.norm(a - b) / nb) if nb > 0 else float("inf")


def _records(u_model: ArrayLike, u_meas: ArrayLike) -> tuple[NDArray[np.float64],
                                                           NDArray[np.float64]]:
    a = np.asarray(u_model, dtype=float)
    b = np.asarray(u_meas, dtype=float)
    if a.shape != b.shape or a.ndim != 1:
        raise InputError("spectral_corr: records must be 1-D of the same length",
                         found=f"{a.shape} and {b.shape}")
    return a, b


def _pearson(ma: NDArray[np.float64], mb: NDArray[np.float64]) -> float:
    if np.std(ma) == 0 or np.std(mb) == 0:
        return 0.0
    return float(np.corrcoef(ma, mb)[0, 1])


def spectral_corr_periodogram(u_model: ArrayLike, u_meas: ArrayLike, fs: float, *,
                              f_max_hz: float = F_CUT_HZ) -> float:
    """Pearson correlation of ``|FFT|`` of two records over the bins 0..``f_max_hz``."""
    a, b = _records(u_model, u_meas)
    freq = sfft.rfftfreq(a.size, 1.0 / fs)
    sel = freq <= f_max_hz
    return _pearson(np.abs(sfft.rfft(a))[sel], np.abs(sfft.rfft(b))[sel])


def spectral_corr(u_model: ArrayLike, u_meas: ArrayLike, fs: float, *,
                  f_max_hz: float = F_CUT_HZ, nperseg: int | None = None) -> float:
    """Pearson correlation of the Welch amplitude spectra of two records over
    0..``f_max_hz`` (module docstring; ``nperseg`` default: the H1 estimator's)."""
    from vfmodel.signals.h1 import default_nperseg, welch_power

    a, b = _records(u_model, u_meas)
    n = default_nperseg(a.size) if nperseg is None else int(nperseg)
    amp = np.sqrt(welch_power(np.stack([a, b]), n))
    sel = sfft.rfftfreq(n, 1.0 / fs) <= f_max_hz
    return _pearson(amp[0, sel], amp[1, sel])
