"""Bearing physics: the capacitive divider, the bearing-voltage ratio and the film.

The one home of the bearing's lumped physics: the divider capacitances of the grey-box
network (:func:`divider_capacitances`, paper Fig. 1, eq. 1), the effective bearing
capacitance of the network (:func:`bearing_capacitance`), the equivalent lubricant film
(:func:`film_equivalent`), the ratio and its inverse (:func:`bvr_from_capacitances`,
:func:`c_b_from_bvr`), the frequency-dependent ratio of a record (:func:`bvr`, paper eq. 3)
and the classical BVR baseline (paper eq. 22, Table IV).

The conventional model (paper Fig. 1, its ref. [11]) is a capacitive divider:

    u_B(t) = BVR * u_CM(t),   u_CM = (u_U + u_V + u_W) / 3                    (eq. 22)
    BVR = C_wr / (C_wr + C_rf + 2 C_b)                                         (eq. 1)

with ``C_wr`` (winding-rotor, all phases) and ``C_rf`` (rotor-frame) taken from the
identified grey-box network (:func:`divider_capacitances`) and
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

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import scipy.fft as sfft
from numpy.typing import ArrayLike, NDArray

from vfmodel._choices import BearingState
from vfmodel.circuit.netlist import Circuit
from vfmodel.errors import InputError
from vfmodel.greybox.assembly import _pget
from vfmodel.greybox.effects import PAPER_EFFECTS, check_effects
from vfmodel.greybox.params import ParamSet
from vfmodel.greybox.substructures import bearing
from vfmodel.signals.checks import as_channels, check_finite, check_fs
from vfmodel.signals.h1 import h1_analysis

__all__ = [
    "BEARING_C_REF_HZ",
    "C_B_MAX_F",
    "BvrBaseline",
    "BvrResult",
    "average_bvr",
    "bearing_capacitance",
    "bvr",
    "bvr_baseline",
    "bvr_from_capacitances",
    "c_b_from_bvr",
    "common_mode",
    "divider_capacitances",
    "film_equivalent",
    "film_time_constant",
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


def divider_capacitances(params: ParamSet | Mapping[str, float],
                         effects: Iterable[str] = PAPER_EFFECTS) -> dict[str, float]:
    """Low-frequency capacitances of the conventional divider model (paper Fig. 1, eq. 1).

    ``c_wr`` (all three phases), ``c_rf`` (air gap), ``c_b`` (one bearing: series film
    layers plus edge and air capacitance, each insulation value including its dielectric
    branch ``(1 + k_d)`` when enabled) and ``bvr = c_wr / (c_wr + c_rf + 2 c_b)``, valid in
    the rotating state between the film's RC corner and the first resonance.
    """
    eff = check_effects(effects)
    v = _pget(params)
    kd = 1 + v["insulation.k_d"] if "insulation_dielectric_loss" in eff else 1.0
    c_wr = 3 * v["insulation.C_wr"] * kd
    c_rf = v["airgap.C_rf"] * kd
    c1 = v["lubricant.C_1"] * (1 + v["lubricant.k_d"]
                               if "lubricant_dielectric_loss" in eff else 1.0)
    film = c1 * v["lubricant.C_2"] / (c1 + v["lubricant.C_2"]) \
        if "lubricant_two_layer" in eff else c1
    c_b = film + v["bearing.C_air"] + (v["bearing.C_edge"]
                                       if "hertzian_edge_capacitance" in eff else 0.0)
    return {"c_wr": c_wr, "c_rf": c_rf, "c_b": c_b, "bvr": c_wr / (c_wr + c_rf + 2 * c_b)}


def film_time_constant(params: ParamSet | Mapping[str, float],
                       effects: Iterable[str]) -> float:
    """Slowest relaxation time of the lubricant film's layers (s): ``R_1 C_1 (1 + k_d)``
    and, with the two-layer film, ``R_2 C_2`` (each layer's resistance discharges its own
    capacitance). The film's DC resistance (:func:`film_equivalent`) shows in a record
    only through these discharges: a layer whose corner ``1 / (2 pi tau)`` lies below the
    record's frequency resolution ``1 / T`` acts there as a capacitor, and its resistance
    is an extrapolation to 0 Hz."""
    eff = set(effects)
    v = _pget(params)
    c1 = v["lubricant.C_1"] * (1 + v["lubricant.k_d"]
                               if "lubricant_dielectric_loss" in eff else 1.0)
    tau = v["lubricant.R_1"] * c1
    if "lubricant_two_layer" in eff:
        tau = max(tau, v["lubricant.R_2"] * v["lubricant.C_2"])
    return float(tau)


BEARING_C_REF_HZ = 100e3
"""Frequency of :func:`bearing_capacitance`: inside the plateau band (the capacitive
divider after each edge), above the film's RC corner and below the ringing."""


def bearing_capacitance(params: ParamSet | Mapping[str, float],
                        effects: Iterable[str] = PAPER_EFFECTS,
                        state: BearingState = "rotating",
                        freq_hz: float = BEARING_C_REF_HZ) -> float:
    """Effective capacitance ``Im(Y) / (2 pi f)`` of one bearing between shaft and frame at
    ``freq_hz`` (film layers, contact, balls, edge and air capacitance together).

    Unlike :func:`divider_capacitances` (``c_b``: capacitances added by hand) this is the
    network's own admittance, so it is defined for any bearing structure (e.g. inner and
    outer race contacts, a conducting thickener layer) and comparable between them.
    """
    eff = check_effects(effects)
    v = _pget(params)
    els = bearing(
        "b", "S", "0", c_air=v["bearing.C_air"], ball_r=v["ball.R_dc"],
        ball_l_ext=v["ball.L_ext"], ball_l_int=v["ball.L_int"], ball_rho=v["ball.rho"],
        ball_skin="ball_skin_effect" in eff, r_h=v["bearing.R_h"], r_1=v["lubricant.R_1"],
        c_1=v["lubricant.C_1"], two_layer="lubricant_two_layer" in eff, r_2=v["lubricant.R_2"],
        c_2=v["lubricant.C_2"], lub_loss="lubricant_dielectric_loss" in eff,
        k_d=v["lubricant.k_d"], tau_d=v["lubricant.tau_d"],
        edge="hertzian_edge_capacitance" in eff, c_edge=v["bearing.C_edge"],
        metallic="metallic_contact" in eff, closed=state == "standstill")
    z = Circuit(elements=tuple(els)).port_impedance([freq_hz], [("S", "0")])[0, 0, 0]
    return float((1.0 / z).imag / (2 * np.pi * freq_hz))


def film_equivalent(params: ParamSet, effects: Iterable[str]) -> dict[str, float]:
    """Equivalent lubricant-film R and C of one bearing (``results.json`` ``lubricant``).

    ``r_ohm``: DC resistance of the film, ``R_1 (+ R_2)`` (layers in series; the loss branch
    carries no DC). ``c_f``: its capacitance above the RC corners, ``C_1 (1 + k_d)`` in
    series with ``C_2`` (two-layer film), the film part of the paper's ``C_b``.
    """
    eff = set(effects)
    dc = divider_capacitances(params, eff)
    c_film = dc["c_b"] - params["bearing.C_air"] - (
        params["bearing.C_edge"] if "hertzian_edge_capacitance" in eff else 0.0)
    r = params["lubricant.R_1"] + (params["lubricant.R_2"] if "lubricant_two_layer" in eff
                                   else 0.0)
    return {"r_ohm": float(r), "c_f": float(c_film)}


@dataclass(frozen=True)
class BvrResult:
    """Frequency-dependent bearing voltage ratio ``BVR(f) = U_b/U_CM`` (paper eq. 3).

    ``coherence`` is the ordinary coherence between ``u_CM`` and ``u_B`` for the H1
    method; for the plain ratio of Fourier transforms it is all NaN (not defined).
    """

    freq_hz: NDArray[np.float64]
    bvr: NDArray[np.complex128]
    coherence: NDArray[np.float64]
    method: str


def bvr(
    u_u: ArrayLike,
    u_v: ArrayLike,
    u_w: ArrayLike,
    u_b: ArrayLike,
    fs: float,
    *,
    method: Literal["h1", "ratio"] = "h1",
    **welch: Any,
) -> BvrResult:
    """``BVR(f) = U_b(j w) / U_CM(j w)`` with ``u_CM = (u_U + u_V + u_W) / 3`` (paper eq. 3).

    ``method="ratio"``: the plain ratio of the whole-record Fourier transforms (the paper's
    eqs. 3-5; noisy where ``U_CM`` is small). ``method="h1"`` (default): the single-input
    H1 estimate ``G_{b,cm} / G_{cm,cm}`` with Welch averaging (``welch`` keywords as in
    :func:`h1_analysis`), robust to output noise and with a coherence.
    """
    fs = check_fs(fs)
    z, nm = as_channels([np.asarray(c) for c in (u_u, u_v, u_w, u_b)], "bvr",
                        ["u_U", "u_V", "u_W", "u_B"])
    check_finite(z, nm, "bvr")
    u_cm = z[:3].mean(axis=0)
    if method == "ratio":
        cm = sfft.rfft(u_cm)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = sfft.rfft(z[3]) / cm
        freq = sfft.rfftfreq(z.shape[1], 1 / fs)
        return BvrResult(freq, ratio, np.full(freq.size, np.nan), "ratio")
    if method != "h1":
        raise InputError("unknown method", place="bvr: method", found=repr(method),
                         expected="'h1' or 'ratio'")
    res = h1_analysis(u_cm[None, :], z[3], fs, input_names=["u_CM"], output_names=["u_B"],
                      **welch)
    return BvrResult(res.freq_hz, res.h[:, 0, 0], res.coherence[:, 0], "h1")
