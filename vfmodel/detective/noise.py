"""Noise level of measured spectra and transfers, the yardstick of every detective test.

Spectra: the data are fitted by a high-order black-box rational model (vector fitting with
automatic order, which stops at the noise floor); the residual of that fit in
``log H`` is the noise, with the degrees of freedom of the fit removed:
``sigma^2 = sum |log(H_bb / H)|^2 / (2 n - n_par)``, ``n_par = 2 order + 1`` real
unknowns (poles and residues of a pole-residue model, plus D). A second, model-free
estimate from second differences of ``log H`` on the frequency grid (noise of variance
``6 sigma^2``; the median absolute deviation ignores the few resonances) guards against
a black-box fit that could not follow the data (then its residual is not noise): the
black-box value is used unless it exceeds the second-difference one by more than
``mismatch`` (then the latter is used). Transfers (H1 estimates): the standard deviation
follows from the coherence, ``var H1 ~ (1 - coh^2) |H|^2 / (2 n_d coh^2)``.

References
----------
B. Gustavsen, A. Semlyen, IEEE Trans. Power Delivery 14(3), 1999. doi:10.1109/61.772353
J. S. Bendat, A. G. Piersol, *Random Data*, 4th ed., Wiley, 2010, eq. (9.90).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.rational_model import RationalModel
from vfmodel.signals.spectral import log_noise_sigma

__all__ = ["SpectrumNoise", "h1_sigma", "second_difference_sigma", "spectrum_noise"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]


@dataclass(frozen=True)
class SpectrumNoise:
    """Noise of one spectrum: ``sigma`` of ``Re log H`` and ``Im log H`` (per point)."""

    sigma: float
    method: str
    sigma_blackbox: float | None
    sigma_second_difference: float
    blackbox: RationalModel | None


def second_difference_sigma(values: ArrC) -> float:
    """Noise std of ``Re/Im log H`` from second differences (floored at 1e-6)."""
    return log_noise_sigma(values, floor=1e-6)


def spectrum_noise(freq_hz: ArrF, values: ArrC, *, mismatch: float = 1.5,
                   max_order: int | None = None) -> SpectrumNoise:
    """Noise estimate of a 1-port spectrum (see the module docstring)."""
    from vfmodel.fitting.vectfit import vector_fit

    f = np.asarray(freq_hz, dtype=float)
    h = np.asarray(values, dtype=complex)
    s2 = second_difference_sigma(h)
    bb: RationalModel | None = None
    s_bb: float | None = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mo = max_order if max_order is not None else min(60, max(4, f.size // 4))
            bb, rep = vector_fit(FrequencyData(f, h, kind="Z"), "auto", weighting="inv_abs",
                                 fit_e=True, max_order=mo)
        hb = bb(f)[:, 0, 0]
        lr = np.log(hb / h)
        n_par = 2 * bb.n_poles + 2
        dof = max(2 * f.size - n_par, 1)
        s_bb = float(np.sqrt(np.sum(lr.real**2 + np.angle(hb / h) ** 2) / dof))
        del rep, lr
    except Exception:  # any failure of the black box falls back to second differences
        bb, s_bb = None, None
    if s_bb is not None and np.isfinite(s_bb) and s_bb <= mismatch * s2:
        return SpectrumNoise(max(s_bb, 1e-6), "blackbox", s_bb, s2, bb)
    return SpectrumNoise(s2, "second_difference", s_bb, s2, bb)


def h1_sigma(h: ArrC, coherence: ArrF, n_averages: int) -> ArrF:
    """Standard deviation of ``|H1|`` relative to ``|H1|`` (random error of the estimate),
    ``sqrt((1 - coh^2) / (2 n_d coh^2))`` (Bendat & Piersol eq. 9.90)."""
    c2 = np.clip(np.asarray(coherence, dtype=float) ** 2, 1e-12, 1.0)
    return np.sqrt((1 - c2) / (2 * max(n_averages, 1) * c2)) * np.ones_like(np.abs(h))
