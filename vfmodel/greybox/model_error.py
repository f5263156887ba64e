"""Structural model error of the plateau level, estimated from the record (issue 19).

The 95 % intervals of :func:`.lsq.log_interval` hold the measurement noise the stage's
covariance sees. A network that differs in structure from the machine (two bearings, a
thickener layer, cable sections) fits the record with a systematic error the noise does not
describe: on independent benches the model's common-mode bearing transfer at 100 kHz
(``H_cm``, :meth:`.objective.RecordTransfer.cm_transfer`) was within 1 % of the truth in
the median but outside its noise interval in 64 % of the cases.

This module measures that error on the data alone. The non-parametric estimate of the
common-mode transfer is the sum over the three terminals of the measured H1 transfer of
``u_B`` (Bendat & Piersol, ch. 7); the model's counterpart is the same estimator applied to
the modelled output from the same measured terminal voltages
(:meth:`.objective.BearingTerm.h1_model`), so the estimator's leakage and input-noise bias
cancel. On the H1 bins of a band around ``f0`` (half an octave either side; the term's
bins, where the coherence is usable) the log-magnitude ratio is

    delta_k = log |sum_i H1_meas,ik| - log |sum_i H1_model,ik|,

with the noise variance of the measured H1 sum (Bendat & Piersol, sec. 9.3:
``E[dH_a dH_b^*] = s^2 [conj(G_xx)^-1]_ab``, ``s^2 = (1 - gamma^2) G_yy / (n_eff - 3)``)

    v_k = s_k^2 1^T G_xx,k^-1 1 / (2 |S_k|^2)

(the real part of a circular complex error carries half its variance). The discrepancy
variance is the method-of-moments estimate (as the between-study variance of DerSimonian &
Laird 1986) of the model discrepancy of Kennedy & O'Hagan (2001), taken as zero-mean with
variance ``tau^2`` near ``f0``:

    tau^2 = max(0, mean_k (delta_k^2 - v_k)).

:func:`.lsq.log_interval` adds it to a derived quantity ``q`` through the posterior
regression of ``log q`` on ``log H_cm`` (the shift of the estimate of ``q`` when the plateau
level the fit matched is off by one unit): ``var log q += (beta tau)^2``,
``beta = g_q^T C g_H / g_H^T C g_H``; ``beta = 1`` for ``H_cm`` itself. ``reproduce`` takes
``C`` as the speed's own stage covariance (the lubricant parameters that fit moves to meet
the level; the machine is held there): with the machine's covariance added, ``C_b`` and
``H_cm`` are nearly uncorrelated while ``H_cm``'s variance is tiny, and the regression
gave ``beta`` from 17 to 199 at the speeds of one bench (independent bench 107).

References
----------
M. C. Kennedy, A. O'Hagan, "Bayesian calibration of computer models", J. R. Stat. Soc. B
63(3), 425-464, 2001. doi:10.1111/1467-9868.00294
R. DerSimonian, N. Laird, "Meta-analysis in clinical trials", Controlled Clinical Trials
7(3), 177-188, 1986. doi:10.1016/0197-2456(86)90046-2
J. S. Bendat, A. G. Piersol, *Random Data*, 4th ed., Wiley, 2010, sec. 9.3.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vfmodel.greybox.bearing import BEARING_C_REF_HZ
from vfmodel.signals.h1 import H1Result

__all__ = ["BAND_OCTAVES", "PlateauDiscrepancy", "discrepancy_tau", "plateau_discrepancy"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]

BAND_OCTAVES = 0.5
"""Half width of the band around ``f0`` in octaves (``f0 / sqrt 2 .. f0 sqrt 2``)."""


@dataclass(frozen=True)
class PlateauDiscrepancy:
    """Log-magnitude ratio measured / model of the common-mode H1 transfer on the bins of
    the band (``freq_hz``), its noise variance, and ``tau`` (:func:`discrepancy_tau`)."""

    freq_hz: ArrF
    log_ratio: ArrF
    noise_var: ArrF
    tau: float

    def to_json_dict(self) -> dict[str, Any]:
        return {"estimate": "tau^2 = max(0, mean(delta^2 - noise var)) of the log ratio "
                            "|sum H1 measured| / |sum H1 model| on the bins of the band",
                "band_hz": [float(self.freq_hz[0]), float(self.freq_hz[-1])]
                if self.freq_hz.size else None,
                "bins": int(self.freq_hz.size),
                "rms_log_ratio": float(np.sqrt(np.mean(self.log_ratio ** 2)))
                if self.freq_hz.size else None,
                "noise_std_log": float(np.sqrt(np.mean(self.noise_var)))
                if self.freq_hz.size else None,
                "tau_log": self.tau,
                "freq_hz": self.freq_hz.tolist(), "log_ratio": self.log_ratio.tolist()}


def discrepancy_tau(log_ratio: ArrF, noise_var: ArrF) -> float:
    """``sqrt(max(0, mean(log_ratio^2 - noise_var)))``; 0 without bins."""
    if log_ratio.size == 0:
        return 0.0
    return float(np.sqrt(max(float(np.mean(log_ratio ** 2 - noise_var)), 0.0)))


def cm_noise_var(h1: H1Result, idx: NDArray[np.intp]) -> ArrF:
    """Variance of ``sum_i H1_i`` (complex) on the H1 bins ``idx`` (see the module text)."""
    s2 = h1.noise_power(idx)
    ones = np.ones(h1.gxx.shape[1])
    q = np.real(np.einsum("i,fij,j->f", ones, np.linalg.inv(h1.gxx[idx]), ones))
    return np.asarray(s2 * np.maximum(q, 0.0), dtype=float)


def plateau_discrepancy(h1: H1Result, mask: NDArray[np.bool_], h_meas: ArrC, h_model: ArrC,
                        f0_hz: float = BEARING_C_REF_HZ,
                        octaves: float = BAND_OCTAVES) -> PlateauDiscrepancy:
    """The discrepancy of the model's common-mode transfer near ``f0_hz``.

    ``mask`` selects the bins of ``h1`` that ``h_meas`` and ``h_model`` (n_bins, n_in: the
    measured and modelled H1 rows of the output) hold, e.g. a
    :class:`.objective.BearingTerm`'s ``op.mask``, ``h_meas`` and ``h1_model(params)``."""
    idx = np.flatnonzero(mask)
    f = h1.freq_hz[idx]
    band = (f >= f0_hz * 2.0 ** -octaves) & (f <= f0_hz * 2.0 ** octaves)
    sm = np.sum(h_meas[band], axis=1)
    so = np.sum(h_model[band], axis=1)
    ok = (np.abs(sm) > 0) & (np.abs(so) > 0)
    sm, so, fb = sm[ok], so[ok], f[band][ok]
    ratio = np.log(np.abs(sm)) - np.log(np.abs(so))
    var = cm_noise_var(h1, idx[band][ok]) / (2.0 * np.abs(sm) ** 2)
    return PlateauDiscrepancy(np.asarray(fb, dtype=float), np.asarray(ratio, dtype=float),
                              np.asarray(var, dtype=float), discrepancy_tau(ratio, var))
