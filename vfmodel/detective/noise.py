"""Noise level of measured spectra and transfers, the yardstick of every detective test.

Spectra: the data are fitted by a high-order black-box rational model; the residual of
that fit in ``log H`` is the noise, with the degrees of freedom of the fit removed:
``sigma^2 = sum |log(H_bb / H)|^2 / (2 n - n_par)``, ``n_par = 2 order + 2`` real
unknowns (poles and residues of a pole-residue model, plus D and E). The order starts at
the one vector fitting's automatic order picks and grows (by pole pairs, up to
``extra_orders`` pairs) while the extended-sum-of-squares F test says the extra poles
explain more than noise (Seber & Wild, sec. 5.3; level ``f_alpha``): the automatic order
stops early on spectra with weak resonances, and every structure the black box leaves in
its residual inflates the noise (on the concealed benches by 0-40 %, so that a
network at the noise showed chi2_red ~0.85). A second, model-free
estimate from second differences of ``log H`` on the frequency grid (noise of variance
``6 sigma^2``; the median absolute deviation ignores the few resonances) guards against
a black-box fit that could not follow the data (then its residual is not noise): the
black-box value is used unless it exceeds the second-difference one by more than
``mismatch`` (then the latter is used).

References
----------
B. Gustavsen, A. Semlyen, IEEE Trans. Power Delivery 14(3), 1999. doi:10.1109/61.772353
G. A. F. Seber, C. J. Wild, *Nonlinear Regression*, Wiley, 1989, sec. 5.3 (F test).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.rational_model import RationalModel
from vfmodel.signals.spectral import log_noise_sigma

__all__ = ["SpectrumNoise", "spectrum_noise"]

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


def _log_rss(model: RationalModel, f: ArrF, h: ArrC) -> tuple[float, int]:
    """Residual sum of squares of ``log H`` and the number of real unknowns of ``model``."""
    hb = model(f)[:, 0, 0]
    lr = np.log(hb / h)
    return float(np.sum(lr.real**2 + np.angle(hb / h) ** 2)), 2 * model.n_poles + 2


def spectrum_noise(freq_hz: ArrF, values: ArrC, *, mismatch: float = 1.5,
                   max_order: int | None = None, extra_orders: int = 5,
                   f_alpha: float = 1e-3) -> SpectrumNoise:
    """Noise estimate of a 1-port spectrum (see the module docstring)."""
    from vfmodel.fitting.vectfit import vector_fit

    f = np.asarray(freq_hz, dtype=float)
    h = np.asarray(values, dtype=complex)
    s2 = log_noise_sigma(h, floor=1e-6)        # second differences of log H
    bb: RationalModel | None = None
    s_bb: float | None = None
    m = 2 * f.size
    data = FrequencyData(f, h, kind="Z")
    mo = max_order if max_order is not None else min(60, max(4, f.size // 4))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            bb, _ = vector_fit(data, "auto", weighting="inv_abs", fit_e=True, max_order=mo)
            rss, k = _log_rss(bb, f, h)
            order = bb.n_poles
            for _ in range(extra_orders):
                order += 2
                if order > mo or m - (2 * order + 2) < 10:
                    break
                try:
                    cand, _ = vector_fit(data, order, weighting="inv_abs", fit_e=True)
                except Exception:  # an order that fails is skipped
                    continue
                rss_c, k_c = _log_rss(cand, f, h)
                if not (np.isfinite(rss_c) and rss_c < rss):
                    continue
                fstat = (rss - rss_c) / (k_c - k) / (rss_c / (m - k_c))
                if fstat > stats.f.isf(f_alpha, k_c - k, m - k_c):
                    bb, rss, k = cand, rss_c, k_c
        s_bb = float(np.sqrt(rss / max(m - k, 1)))
    except Exception:  # any failure of the black box falls back to second differences
        bb, s_bb = None, None
    if s_bb is not None and np.isfinite(s_bb) and s_bb <= mismatch * s2:
        return SpectrumNoise(max(s_bb, 1e-6), "blackbox", s_bb, s2, bb)
    return SpectrumNoise(s2, "second_difference", s_bb, s2, bb)
