"""Periodic steady state: FFT of one period x transfer x inverse FFT (the one home).

A record of ``n`` samples holding an integer number of periods of a periodic input is the
periodic extension of itself; the response of an LTI system to it, after every transient
has settled, has the rfft bins ``Y_k = sum_i H_i(f_k) X_i,k``. Film time constants far
longer than the record and a record that does not start from rest are then exact. Every
periodic steady state of the package goes through :func:`periodic_response`
(:func:`vfmodel.signals.simulate.simulate_periodic` for rational models; the network
transfers of the identification, of ``predict`` and of the drive model in
:mod:`vfmodel.greybox`), and every exact resampling of a band-limited periodic record through
:func:`resample_periodic`.
"""

from __future__ import annotations

import numpy as np
import scipy.fft as sfft
from numpy.typing import NDArray

__all__ = ["periodic_response", "resample_periodic"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]


def resample_periodic(spec: ArrC, n: int, n_new: int | None = None) -> ArrF:
    """Samples (..., n_new) of the periodic signal whose first rfft bins of an ``n``-sample
    record are ``spec`` (..., n_bins); the bins not given are zero (band-limited).

    ``n_new`` (default ``n``) other than ``n`` resamples exactly (the spectrum is truncated
    or zero-padded, scaled by ``n_new / n``)."""
    n_new = n if n_new is None else n_new
    out = np.zeros((*spec.shape[:-1], n_new // 2 + 1), complex)
    k = min(spec.shape[-1], n_new // 2 + 1)
    out[..., :k] = spec[..., :k] * (n_new / n)
    return np.asarray(sfft.irfft(out, n=n_new, axis=-1), dtype=float)


def periodic_response(h_bins: ArrC, x_bins: ArrC, n: int, n_new: int | None = None) -> ArrF:
    """Periodic steady-state output (n_out, n_new) of transfers ``h_bins`` (n_bins, n_out,
    n_in) on the first rfft bins of an ``n``-sample period, driven by inputs with those rfft
    bins ``x_bins`` (n_in, n_bins); higher bins are zero. ``n_new``: see
    :func:`resample_periodic`."""
    yb = np.einsum("foi,if->of", h_bins, x_bins)
    return resample_periodic(yb, n, n_new)
