"""Classical capacitive bearing-voltage-ratio model (reference paper eq. 1, eq. 22, Table IV).

The conventional model (paper Fig. 1, its ref. [11]) is a capacitive divider:

    u_B(t) = BVR * u_CM(t),   u_CM = (u_U + u_V + u_W) / 3                    (eq. 22)
    BVR = C_wr / (C_wr + C_rf + 2 C_b)                                         (eq. 1)

with ``C_wr`` (winding-rotor, all phases) and ``C_rf`` (rotor-frame) taken from the
identified grey-box network (:func:`vfmodel.greybox.assembly.divider_capacitances`) and
the bearing capacitance ``C_b`` (identical DE/NDE) determined from the recording: the
*average BVR* is the least-squares gain of the divider model to the record,

    BVR_avg = <u_B, u_CM> / <u_CM, u_CM>

(both signals after the 10 MHz filter), i.e. the output-error fit of eq. 21 for a
frequency-independent transfer; eq. 1 solved for ``C_b`` gives
``C_b = (C_wr / BVR_avg - C_wr - C_rf) / 2``. At standstill the metallic contact makes the
average BVR nearly zero and ``C_b`` unrealistically large (paper Table IV: "upper limit"):
``C_b`` is then clipped at ``c_b_max`` and reported as ``None``.

References
----------
S. Chen, T. A. Lipo, D. Fitzgerald, "Modeling of motor bearing currents in PWM inverter
drives", IEEE Trans. Ind. Appl. 32(6), 1365-1370, 1996. doi:10.1109/28.556640
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vfmodel.errors import InputError

__all__ = [
    "C_B_MAX_F",
    "BvrBaseline",
    "average_bvr",
    "bvr_baseline",
    "bvr_from_capacitances",
    "c_b_from_bvr",
    "common_mode",
    "predict_bvr",
]

C_B_MAX_F = 1e-6
"""Upper limit of the bearing capacitance (F): a larger C_b means a conductive bearing."""


@dataclass(frozen=True)
class BvrBaseline:
    """The divider model at one speed.

    Attributes
    ----------
    c_wr_f, c_rf_f : float
        Winding-rotor and rotor-frame capacitances (F).
    bvr_average : float
        Least-squares gain of ``u_B`` on ``u_CM`` of the record.
    c_b_f : float or None
        Bearing capacitance from eq. 1; None when it hits the upper limit ``C_B_MAX_F``.
    bvr : float
        BVR of the divider model used for the prediction (eq. 1 with the clipped ``C_b``).
    """

    c_wr_f: float
    c_rf_f: float
    bvr_average: float
    c_b_f: float | None
    bvr: float


def common_mode(terminals: ArrayLike) -> NDArray[np.float64]:
    """``u_CM = (u_U + u_V + u_W) / 3`` (eq. 22) of terminals (3, n)."""
    x = np.asarray(terminals, dtype=float)
    if x.ndim != 2 or x.shape[0] != 3:
        raise InputError("terminals must be (3, n_samples)", found=f"shape {x.shape}")
    return np.asarray(x.mean(axis=0), dtype=float)


def average_bvr(u_cm: ArrayLike, u_b: ArrayLike) -> float:
    """Least-squares gain ``<u_B, u_CM> / <u_CM, u_CM>``."""
    a = np.asarray(u_cm, dtype=float)
    b = np.asarray(u_b, dtype=float)
    den = float(a @ a)
    if den <= 0:
        raise InputError("common-mode voltage is zero: the BVR is not defined")
    return float(a @ b) / den


def bvr_from_capacitances(c_wr: float, c_rf: float, c_b: float) -> float:
    """Eq. 1: ``C_wr / (C_wr + C_rf + 2 C_b)``."""
    return c_wr / (c_wr + c_rf + 2.0 * c_b)


def c_b_from_bvr(bvr: float, c_wr: float, c_rf: float,
                 c_b_max: float = C_B_MAX_F) -> tuple[float | None, float]:
    """Eq. 1 solved for ``C_b``: ``(c_b or None at the upper limit, bvr of the model)``.

    A BVR above ``C_wr / (C_wr + C_rf)`` (no bearing capacitance could explain it) gives
    ``C_b = 0``.
    """
    lo = bvr_from_capacitances(c_wr, c_rf, c_b_max)
    if not bvr > lo:
        return None, lo
    c_b = max(0.0, (c_wr / bvr - c_wr - c_rf) / 2.0)
    return c_b, bvr_from_capacitances(c_wr, c_rf, c_b)


def bvr_baseline(c_wr: float, c_rf: float, terminals: ArrayLike, u_b: ArrayLike,
                 c_b_max: float = C_B_MAX_F) -> BvrBaseline:
    """Divider model of one (filtered) record: average BVR, ``C_b`` and the model BVR."""
    avg = average_bvr(common_mode(terminals), u_b)
    c_b, bvr = c_b_from_bvr(avg, c_wr, c_rf, c_b_max)
    return BvrBaseline(float(c_wr), float(c_rf), avg, c_b, bvr)


def predict_bvr(baseline: BvrBaseline, terminals: ArrayLike) -> NDArray[np.float64]:
    """Bearing voltage of the divider model: ``BVR * u_CM`` (eq. 22)."""
    return baseline.bvr * common_mode(terminals)
