"""simulate against ngspice .tran of the same three-phase RLC bearing network."""

from __future__ import annotations

import numpy as np
import pytest

from benches.three_phase import FS, netlist, network_model, pwm_breakpoints
from vfmodel.circuit.ngspice import ngspice_available, run_tran
from vfmodel.signals.simulate import simulate

pytestmark = [
    pytest.mark.ngspice,
    pytest.mark.skipif(not ngspice_available(), reason="ngspice not installed"),
]

def test_simulate_matches_ngspice_tran() -> None:
    n = 25_000  # 0.25 ms: two PWM periods
    bps = pwm_breakpoints(n)
    tt = np.arange(n) / FS
    u = np.array([np.interp(tt, t, v) for t, v in bps])
    model = network_model()
    tran = run_tran(netlist(bps), ["v(B)"], t_step_s=1 / FS, t_stop_s=(n - 1) / FS,
                    t_max_s=2e-9, options={"reltol": 1e-6, "abstol": 1e-12, "vntol": 1e-9})
    ref = tran.values[0]
    assert ref.size == n
    peak = np.max(np.abs(ref))
    y_lin = simulate(model, u, FS, input_model="linear")[0]
    y_bl = simulate(model, u, FS)[0]
    # ngspice's own trapezoidal error with 2 ns steps is ~0.15 % of the peak here
    assert np.max(np.abs(y_lin - ref)) < 0.005 * peak
    assert np.max(np.abs(y_bl - ref)) < 0.005 * peak
