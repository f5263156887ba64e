"""The independent bench's further measurements (CONTRACT section 2a, issue 14): the
drive-end bearing voltage, the common-mode current and the Shaft-Frame impedance, checked
against independent computations on the bench's own circuit."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from benches.independent import (
    INV,
    PHASES,
    SHAFT_FRAME,
    bearing_capacitance,
    draw,
    extra_response,
    machine,
    shaft_frame_impedance,
    with_cable,
)

F = np.logspace(4, 7, 7)


def _responses(d: object, speed: float) -> tuple[np.ndarray, np.ndarray]:
    net = with_cable(machine(d, speed), d)  # type: ignore[arg-type]
    h = net.mna.response(F, INV, ("U", "V", "W", "SN"))
    return h, extra_response(net, d, F, h[:, :3, :])  # type: ignore[arg-type]


def test_de_equals_nde_on_a_symmetric_bench() -> None:
    """Equal bearings, shaft halves, rotor splits and frame segments: by symmetry
    v(SD) = v(SN) (to solver precision, 1e-8); the drawn bench is asymmetric (> 1 %)."""
    d = draw(101)
    v = {**d.v, "de_size": 1.0, "shaft_L_D": d.v["shaft_L_N"], "wr_split": 0.5,
         "rf_split": 0.5}
    h, he = _responses(replace(d, v=v), 300.0)
    np.testing.assert_allclose(he[:, 0, :], h[:, 3, :], rtol=1e-8, atol=0)
    h, he = _responses(d, 300.0)
    assert np.max(np.abs(he[:, 0, :] / h[:, 3, :] - 1)) > 0.01


def test_common_mode_current_is_the_sum_of_phase_currents() -> None:
    """i_CM from the cable side (KCL at each terminal) equals 1^T Y V computed from the
    machine alone: Y = inverse of its 3x3 terminal impedance matrix, V the terminal
    voltages of the same drive (rtol 1e-6)."""
    d = draw(102)
    h, he = _responses(d, 100.0)
    pairs = [(p, "0") for p in PHASES]
    z = machine(d, 100.0).mna.response(F, pairs, pairs)       # (f, 3, 3)
    i_phase = np.linalg.solve(z, h[:, :3, :])                 # (f, 3 phases, 3 sources)
    np.testing.assert_allclose(he[:, 1, :], i_phase.sum(axis=1), rtol=1e-6, atol=0)
    # a common-mode current flows through the winding-frame capacitances: |i_CM| grows
    # with frequency like 2 pi f C from 10 to 100 kHz (capacitive, within 20 %)
    u_cm = h[:, :3, :].mean(axis=1)
    c = np.abs(he[:2, 1, 0] / u_cm[:2, 0]) / (2 * np.pi * F[:2])
    assert c[1] == pytest.approx(c[0], rel=0.2)


def test_shaft_frame_impedance_standstill_and_speed() -> None:
    """At standstill the metallic contact shorts the bearings (|Z| at 10 kHz below 5 ohm);
    turning, the path is capacitive (tens of nF: |Z| > 100 ohm, mostly reactive): the
    two bearings' capacitances, the air gap and the rotor-winding path in parallel, at
    100 kHz within 2 % of their sum (the slow Debye branch and the series C_wr-C_wf path
    are approximated; 0.04-0.11 % on benches 101-104)."""
    d = draw(103)
    z0 = shaft_frame_impedance(d, 0.0, F)
    z3 = shaft_frame_impedance(d, 300.0, F)
    assert abs(z0[0]) < 5.0 and abs(z3[0]) > 100.0 and -z3[0].imag > 3 * abs(z3[0].real)
    v = d.v
    c_b = sum(bearing_capacitance(d, 300.0, size) for size in (1.0, v["de_size"]))
    c_rf = v["C_rf"] * (1 + v["k1"])
    c_wr, c_wf = 3 * v["C_wr"] * (1 + v["k1"]), 3 * v["C_wf"] * (1 + v["k1"])
    c_sum = c_b + c_rf + c_wr * c_wf / (c_wr + c_wf)
    k = int(np.argmin(np.abs(F - 1e5)))
    c_meas = (1 / z3[k]).imag / (2 * np.pi * F[k])
    assert c_meas == pytest.approx(c_sum, rel=0.02)
    assert SHAFT_FRAME == ("SN", "0")


def test_testbench_extras_from_the_truth_network() -> None:
    """The project bench (benches/truth.py + drive): with identical bearings the DE and NDE
    voltages agree (1e-8), and i_CM equals 1^T Y V of the machine alone (1e-6)."""
    from benches.drive_extra import extra_transfer
    from benches.truth import build_truth_network, truth_detail, truth_params
    from vfmodel.greybox.drive import CableSpec, drive_circuit

    det = replace(truth_detail(np.random.default_rng(0), n_coils=2, n_rungs=2),
                  bearing_asym=1.0)
    net = build_truth_network(truth_params(), det, state="rotating")
    cable = CableSpec()
    mna = drive_circuit(net, cable).mna
    he = extra_transfer(mna, cable, F)
    h = mna.response(F, INV, ("U", "V", "W", "SN"))
    np.testing.assert_allclose(he[:, 0, :], h[:, 3, :], rtol=1e-8, atol=0)
    pairs = [(p, "0") for p in PHASES]
    z = net.mna.response(F, pairs, pairs)
    np.testing.assert_allclose(he[:, 1, :], np.linalg.solve(z, h[:, :3, :]).sum(axis=1),
                               rtol=1e-6, atol=0)
    # the bench's own DE bearing (8 % more film capacitance) gives another voltage
    net = build_truth_network(truth_params(), replace(det, bearing_asym=1.08),
                              state="rotating")
    mna = drive_circuit(net, cable).mna
    ratio = extra_transfer(mna, cable, F)[:, 0, :] / mna.response(F, INV, ("SN",))[:, 0, :]
    assert np.max(np.abs(ratio - 1)) > 1e-3


def test_random_start_shifts_the_record_within_the_same_run() -> None:
    """``record(start=x)`` is the same run ending x PWM periods earlier: the overlap of the
    two records agrees to 1e-9 of the peak, sample for sample (same jitter draws)."""
    from benches.independent import record

    d = replace(draw(103), fs_hz=10e6)           # a coarse rate: the run in ~1 s
    a, _ = record(d, 200.0, np.random.default_rng(4), n_periods=2)
    b, _ = record(d, 200.0, np.random.default_rng(4), n_periods=2, start=0.25)
    k = round(0.25 * d.fs_hz / 8e3)
    np.testing.assert_allclose(b[:, k:], a[:, : a.shape[1] - k], rtol=0,
                               atol=1e-9 * np.max(np.abs(a)))
    assert np.max(np.abs(b - a)) > 0.01 * np.max(np.abs(a))   # a shift, not the same
