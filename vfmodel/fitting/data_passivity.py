"""How passive the data themselves are: the passivity violation floor of measured samples.

A passive model cannot come closer to the data than the data's own passive projection:
per frequency, the nearest passive matrix (Frobenius norm) is

- S (bounded real): ``U min(Sigma, 1) V^H`` from the SVD ``H = U Sigma V^H``;
- Z, Y (positive real): the Hermitian part with its negative eigenvalues clipped to 0, plus
  the unchanged skew-Hermitian part.

The floor is the relative RMS distance of the samples to that projection,
``||H - P(H)||_F / ||H||_F`` over all frequencies and entries (the units of
``rel_rms_error``). Measurement noise and calibration of nearly lossless devices give floors
of 1e-4 to 1e-2; an amplifier (gain > 1) gives a floor of tens of percent: its data are
active, and a passive model of them is not a model of the device.

References
----------
N. J. Higham, "Computing a nearest symmetric positive semidefinite matrix", Linear Algebra
Appl. 103 (1988), doi:10.1016/0024-3795(88)90223-6 (clipped eigenvalues);
S. Grivet-Talocia, B. Gustavsen, "Passive Macromodeling", Wiley (2016), ch. 10,
doi:10.1002/9781119140931 (passivity of measured data).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vfmodel.core.frequency_data import FrequencyData

__all__ = ["ACTIVE_FLOOR", "DataPassivity", "data_passivity"]

ACTIVE_FLOOR = 0.05
"""Floor above which the data are called active (enforcement is refused by default)."""

_CHUNK = 4096


@dataclass(frozen=True)
class DataPassivity:
    """Passivity of sampled Z, Y or S data.

    Attributes
    ----------
    floor : float
        ``||H - P(H)||_F / ||H||_F`` over all samples (module docstring).
    point_max : float
        Largest per-frequency relative distance ``||H(f) - P(H(f))||_F / ||H(f)||_F``.
    worst_violation : float
        Largest ``sigma_max - 1`` (S) or ``-lambda_min(Re H) / ||H||_2`` (Z, Y), >= 0.
    worst_freq_hz : float or None
        Where it occurs (None when the data are passive).
    n_violating : int
        Samples with a violation.
    active : bool
        ``floor > ACTIVE_FLOOR``: the data describe an active device.
    """

    floor: float
    point_max: float
    worst_violation: float
    worst_freq_hz: float | None
    n_violating: int
    active: bool


def _distance(
    kind: str, h: NDArray[np.complex128]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per-sample distance to the passive set and the violation (see DataPassivity)."""
    if kind == "S":
        sv = np.linalg.svd(h, compute_uv=False)
        excess = np.clip(sv - 1.0, 0.0, None)
        over = np.asarray(sv[:, 0] - 1.0, dtype=float)
        return np.asarray(np.sqrt(np.sum(excess**2, axis=1)), dtype=float), over
    herm = 0.5 * (h + np.conj(np.swapaxes(h, 1, 2)))
    lam = np.linalg.eigvalsh(herm)
    neg = np.clip(-lam, 0.0, None)
    size = np.maximum(np.linalg.norm(h, 2, axis=(1, 2)), 1e-300)
    viol: NDArray[np.float64] = -lam[:, 0] / size
    return np.sqrt(np.sum(neg**2, axis=1)), viol


def data_passivity(data: FrequencyData) -> DataPassivity | None:
    """Passivity violation floor of square Z, Y or S data (None for other data)."""
    if data.kind not in ("Z", "Y", "S") or data.n_out != data.n_in:
        return None
    dist = np.empty(data.n_freq)
    viol = np.empty(data.n_freq)
    for k in range(0, data.n_freq, _CHUNK):
        sl = slice(k, k + _CHUNK)
        dist[sl], viol[sl] = _distance(data.kind, data.values[sl])
    norm = np.linalg.norm(data.values.reshape(data.n_freq, -1), axis=1)
    total = max(float(np.linalg.norm(norm)), 1e-300)
    floor = float(np.linalg.norm(dist)) / total
    point = dist / np.maximum(norm, 1e-12 * max(float(np.max(norm)), 1e-300))
    k = int(np.argmax(viol))
    worst = max(float(viol[k]), 0.0)
    return DataPassivity(
        floor=floor,
        point_max=float(np.max(point)),
        worst_violation=worst,
        worst_freq_hz=float(data.freq_hz[k]) if worst > 0 else None,
        n_violating=int(np.sum(dist > 0)),
        active=floor > ACTIVE_FLOOR,
    )
