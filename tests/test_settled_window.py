"""Peaks compared on the settled window of a record that is not periodic.

Reference: the exact response of a known RC divider (three 100 pF capacitors from the
terminals to the star point SN, 1 nF || 2.3 kohm from SN to ground: time constant 3 us)
to piecewise-linear terminal voltages, from ``scipy.signal.lsim`` started 100 us before
the record (the network has settled), the record cut from the middle of that run.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as ss

from vfmodel.circuit.netlist import Circuit
from vfmodel.core.recording import Recording
from vfmodel.greybox.metrics import T_END_S, T_SKIP_S, settled_window
from vfmodel.pipeline.predict import predict_recording

C1, C2, R = 100e-12, 1e-9, 2.3e3
FS = 100e6


def _divider() -> Circuit:
    c = Circuit()
    for ph in ("U", "V", "W"):
        c = c.add_capacitor(f"C{ph}", ph, "SN", C1)
    return c.add_capacitor("C2", "SN", "0", C2).add_resistor("R2", "SN", "0", R)


def _terminals(t: np.ndarray, edges: list[tuple[float, int, float]]) -> np.ndarray:
    """+-100 V phases; each edge (time, phase, new level) a 100 ns ramp."""
    u = np.full((3, t.size), -100.0)
    for t0, ph, level in sorted(edges):
        start = np.interp(t0, t, u[ph])
        ramp = np.clip((t - t0) / 100e-9, 0.0, 1.0)
        u[ph] = np.where(t >= t0, start + (level - start) * ramp, u[ph])
    return u


def test_settled_window_margins() -> None:
    w = settled_window(100_000, FS)
    assert (w.start, w.stop) == (round(T_SKIP_S * FS), 100_000 - round(T_END_S * FS))
    short = settled_window(40, FS)        # at least the middle half of a short record
    assert short.start == 10 and short.stop - short.start >= 20
    assert settled_window(1, FS) == slice(0, 1)    # never empty


def test_predicted_peak_of_a_cut_record_on_the_settled_window() -> None:
    pre, rec = 100e-6, 200e-6
    t = np.arange(round((pre + rec) * FS)) / FS
    # phases switch one at a time (duty jitter: not periodic); the record starts with all
    # three high and ends with all three low, so its wrap-around is a 600 V common step
    rng = np.random.default_rng(7)
    edges: list[tuple[float, int, float]] = []
    for t_on in np.arange(20e-6, pre + rec - 50e-6, 50e-6):
        for ph in range(3):
            on = t_on + rng.uniform(0.0, 4e-6) + 8e-6 * ph
            edges += [(on, ph, 100.0), (on + rng.uniform(12e-6, 18e-6), ph, -100.0)]
    edges = [e for e in edges if e[0] < pre - 2e-6 or e[0] > pre + 3e-6]
    edges += [(pre - 2e-6, ph, 100.0) for ph in range(3)]          # all high at the cut
    u = _terminals(t, edges)
    u[:, t > pre + rec - 10e-6] = -100.0                            # all low at the end
    # SN: (3 C1 + C2) dv/dt + v / R = C1 d(u_U + u_V + u_W)/dt
    sys = ss.lti([C1 * R, 0.0], [(3 * C1 + C2) * R, 1.0])
    _, v, _ = ss.lsim(sys, u.sum(axis=0), t)
    cut = t >= pre
    data = np.vstack([u[:, cut], v[cut]])
    out = predict_recording(_divider(), Recording(FS, data, ("u_U", "u_V", "u_W", "u_B")))
    s = out.summary
    assert s["compared_s"] == pytest.approx([T_SKIP_S, rec - T_END_S], abs=0.5 / FS)
    # the model is the exact network: on the settled window its peak is the record's
    assert float(s["rel_err_pct"]) < 0.05  # type: ignore[arg-type]
    # the periodic response wraps around at the record's start: there its peak is that of
    # the 600 V step, about three times any single-phase edge of the record
    whole = float(np.max(np.abs(out.u_b)))
    assert whole > 2.0 * float(s["peak_measured_v"])  # type: ignore[arg-type]
