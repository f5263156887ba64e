"""The H1 estimator of :func:`vfmodel.signals.h1.h1_analysis` as a linear operator on outputs.

Condition 2 of the identification (reference paper, eq. 21) compares the measured H1
transfer with the H1 transfer of the *model output computed from the same measured inputs*
(same estimator, so leakage and bias of the Welch estimate cancel). With the inputs fixed,
``H1 = G_yx G_xx^-1`` is linear in the output ``y``: the windowed, detrended segment
spectra of the inputs and ``G_xx^-1`` are computed once, and every trial output costs one
set of segment FFTs. The operator reproduces ``h1_analysis`` (same window, segment length,
overlap and detrending) to rounding error; see tests/test_greybox_identify.py.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft as sfft
import scipy.signal as ss
from numpy.typing import NDArray

from vfmodel.signals.h1 import H1Result

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]


@dataclass(frozen=True)
class H1Operator:
    """``apply(y)`` = H1 transfer (n_f, n_in) from the fixed inputs to output ``y``."""

    freq_hz: ArrF
    nperseg: int
    noverlap: int
    n_samples: int
    window: ArrF
    xseg_conj: ArrC       # (n_seg, n_f, n_in): conj of windowed segment spectra of inputs
    gxx_inv: ArrC         # (n_f, n_in, n_in) inverse of sum_seg X X^H (unscaled)
    mask: NDArray[np.bool_]   # bins where the operator is evaluated

    def segments(self, y: ArrF) -> ArrC:
        """Windowed, mean-removed segment spectra (n_seg, n_f) of an output."""
        step = self.nperseg - self.noverlap
        n_seg = self.xseg_conj.shape[0]
        idx = np.arange(n_seg)[:, None] * step + np.arange(self.nperseg)[None, :]
        seg = y[..., idx]
        seg = seg - seg.mean(axis=-1, keepdims=True)
        return np.asarray(sfft.rfft(seg * self.window, axis=-1), dtype=complex)

    def apply(self, y: ArrF) -> ArrC:
        """H1 (n_f_masked, n_in) of output ``y`` (n_samples,), or (n_y, n_f_masked, n_in)
        for a stack of outputs (n_y, n_samples)."""
        ys = self.segments(y)[..., self.mask]          # (..., n_seg, n_fm)
        gyx = np.einsum("...sf,sfi->...fi", ys, self.xseg_conj)
        return np.einsum("...fj,fji->...fi", gyx, self.gxx_inv)


def h1_operator(inputs: ArrF, fs: float, ref: H1Result, mask: NDArray[np.bool_]) -> H1Operator:
    """Operator for the same estimator settings as ``ref`` (an ``h1_analysis`` result on
    ``inputs``); ``mask`` selects the frequency bins of ``ref.freq_hz`` to evaluate."""
    del fs
    win = np.asarray(ss.get_window(ref.window, ref.nperseg), dtype=float)
    n = inputs.shape[1]
    step = ref.nperseg - ref.noverlap
    n_seg = (n - ref.nperseg) // step + 1
    idx = np.arange(n_seg)[:, None] * step + np.arange(ref.nperseg)[None, :]
    seg = inputs[:, idx]                                  # (n_in, n_seg, nperseg)
    seg = seg - seg.mean(axis=-1, keepdims=True)
    xs = sfft.rfft(seg * win, axis=-1)                    # (n_in, n_seg, n_f)
    xs = np.transpose(xs, (1, 2, 0))[:, mask, :]          # (n_seg, n_fm, n_in)
    gxx = np.einsum("sfi,sfj->fij", xs, xs.conj())
    return H1Operator(ref.freq_hz, ref.nperseg, ref.noverlap, n, win,
                      np.ascontiguousarray(xs.conj()), np.linalg.inv(gxx), mask)
