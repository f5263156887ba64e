"""Classical BVR model against an analytic capacitive divider (paper eq. 1, eq. 22)."""

from __future__ import annotations

import numpy as np
import pytest

from vfmodel.circuit.netlist import Circuit
from vfmodel.greybox.bearing import (
    C_B_MAX_F,
    average_bvr,
    bvr_baseline,
    bvr_from_capacitances,
    c_b_from_bvr,
    common_mode,
    predict_bvr,
)
from vfmodel.signals.simulate import simulate_periodic

C_WR, C_RF, C_B = 637e-12, 1287e-12, 18.1e-9   # paper Table IV


def _divider() -> Circuit:
    c = Circuit(title="capacitive divider of paper Fig. 1")
    for p in "UVW":
        c = c.add_vsource(f"src.{p}", p, "0", 1.0).add_capacitor(f"C_wr.{p}", p, "SN", C_WR / 3)
    c = c.add_capacitor("C_rf", "SN", "0", C_RF)
    c = c.add_capacitor("C_b.NDE", "SN", "0", C_B).add_capacitor("C_b.DE", "SN", "0", C_B)
    return c.add_resistor("R_leak", "SN", "0", 1e12)   # DC path only


def test_eq1_value() -> None:
    # eq. 1 with Table IV's capacitances
    assert bvr_from_capacitances(C_WR, C_RF, C_B) == pytest.approx(
        637 / (637 + 1287 + 2 * 18100), rel=1e-12)


def test_divider_circuit_recovers_bvr_and_cb() -> None:
    fs, n = 100e6, 20000
    rng = np.random.default_rng(0)
    t = np.arange(n) / fs
    # periodic, band-limited terminal voltages (multisine from 5 kHz to 5 MHz)
    x = np.zeros((3, n))
    for k in range(3):
        for f in rng.choice(np.arange(1, 1000) * fs / n, 30, replace=False):
            x[k] += rng.uniform(1, 10) * np.cos(2 * np.pi * f * t + rng.uniform(0, 6.3))
    h = _divider().transfer(["src.U", "src.V", "src.W"], ["SN"])
    u_b = simulate_periodic(h, x, fs)[0]
    bvr = bvr_from_capacitances(C_WR, C_RF, C_B)
    # the divider's output is BVR * u_CM (eq. 22) above the leak corner (< 1 Hz)
    assert np.max(np.abs(u_b - bvr * common_mode(x))) < 1e-9 * np.max(np.abs(u_b))
    assert average_bvr(common_mode(x), u_b) == pytest.approx(bvr, rel=1e-9)
    bl = bvr_baseline(C_WR, C_RF, x, u_b)
    assert bl.c_b_f == pytest.approx(C_B, rel=1e-8)
    assert bl.bvr == pytest.approx(bvr, rel=1e-9)
    assert np.max(np.abs(predict_bvr(bl, x) - u_b)) < 1e-8 * np.max(np.abs(u_b))


def test_standstill_upper_limit() -> None:
    # a (nearly) zero average BVR cannot be explained by a finite C_b: upper limit, None
    c_b, bvr = c_b_from_bvr(7e-5 * 0.1, C_WR, C_RF)
    assert c_b is None
    assert bvr == pytest.approx(bvr_from_capacitances(C_WR, C_RF, C_B_MAX_F), rel=1e-12)
    c_b, bvr = c_b_from_bvr(-0.01, C_WR, C_RF)
    assert c_b is None
    # a BVR above C_wr / (C_wr + C_rf) needs a negative C_b: clipped to 0
    c_b, bvr = c_b_from_bvr(0.5, C_WR, C_RF)
    assert c_b == 0.0 and bvr == pytest.approx(C_WR / (C_WR + C_RF), rel=1e-12)
