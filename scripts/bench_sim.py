"""Benchmark: vfmodel.simulate vs ngspice .tran on the same three-phase RLC network.

1 ms of three 130 V PWM phase voltages (8 kHz, 50/30 ns edges) at 100 MS/s (1e5 samples)
drive R-L branches into a star node coupled to the shaft (C_wr, C_b, R_b); the output is
the bearing voltage v(B). ngspice runs .tran with a maximum step of ``--tmax`` (default
1 ns, reltol 1e-6); vfmodel.simulate runs on the sampled PWL inputs (input_model "linear":
exact for piecewise-linear sources, and "bandlimited"). One run each; prints both times,
their ratio and the maximum difference relative to the peak.

    .venv/bin/python scripts/bench_sim.py [--tmax 1e-9]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the benches package

from benches.three_phase import FS, netlist, network_model, pwm_breakpoints
from vfmodel.circuit.ngspice import run_tran
from vfmodel.signals.simulate import simulate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tmax", type=float, default=1e-9, help="ngspice maximum step (s)")
    ap.add_argument("--n", type=int, default=100_000, help="samples (1e5 = 1 ms)")
    args = ap.parse_args()
    n = args.n
    bps = pwm_breakpoints(n)
    tt = np.arange(n) / FS
    u = np.array([np.interp(tt, t, v) for t, v in bps])
    model = network_model()

    t0 = time.perf_counter()
    tran = run_tran(netlist(bps), ["v(B)"], t_step_s=1 / FS, t_stop_s=(n - 1) / FS,
                    t_max_s=args.tmax, options={"reltol": 1e-6, "abstol": 1e-12, "vntol": 1e-9})
    t_spice = time.perf_counter() - t0
    ref = tran.values[0]

    t0 = time.perf_counter()
    y_lin = simulate(model, u, FS, input_model="linear")[0]
    t_lin = time.perf_counter() - t0
    t0 = time.perf_counter()
    y_bl = simulate(model, u, FS)[0]
    t_bl = time.perf_counter() - t0

    peak = float(np.max(np.abs(ref)))
    print(f"samples: {n} ({n / FS * 1e3:g} ms at {FS / 1e6:g} MS/s), ngspice tmax {args.tmax:g} s")
    print(f"ngspice .tran:                 {t_spice:8.3f} s")
    print(f"vfmodel.simulate (linear):     {t_lin:8.4f} s   ratio {t_spice / t_lin:7.1f}x   "
          f"max |diff| {np.max(np.abs(y_lin - ref)) / peak * 100:.4f} % of peak ({peak:.4g} V)")
    print(f"vfmodel.simulate (bandlimited):{t_bl:8.4f} s   ratio {t_spice / t_bl:7.1f}x   "
          f"max |diff| {np.max(np.abs(y_bl - ref)) / peak * 100:.4f} % of peak")


if __name__ == "__main__":
    main()
