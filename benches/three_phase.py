"""A three-phase RLC bearing network known in closed form.

Shared by the simulate-vs-ngspice test (``tests/test_simulate_ngspice.py``) and
``scripts/bench_sim.py``: the network's pole-residue model, PWL breakpoints of three PWM
phases on the sample grid and the ngspice netlist of the same network.
"""

from __future__ import annotations

import numpy as np

from vfmodel.core.rational_model import RationalModel

__all__ = ["FS", "netlist", "network_model", "pwm_breakpoints"]

FS = 100e6
# U, V, W -> R_k + L_k -> star node N (C_N, R_N to frame) -> C_wr -> shaft B (C_b, R_b)
R = (2.0, 2.5, 3.0)
L = (2e-6, 2.2e-6, 1.8e-6)
CN, RN, CWR, CB, RB = 2e-9, 2e3, 100e-12, 200e-12, 5e3


def network_model() -> RationalModel:
    """Pole-residue model of v(B)/[u_U, u_V, u_W] from the network's state equations
    M dx/dt = A0 x + B0 u, x = [i_U, i_V, i_W, v_N, v_B]."""
    m = np.diag([*L, CN + CWR, CB + CWR])
    m[3, 4] = m[4, 3] = -CWR
    a0 = np.zeros((5, 5))
    b0 = np.zeros((5, 3))
    for k in range(3):
        a0[k, k], a0[k, 3], b0[k, k], a0[3, k] = -R[k], -1.0, 1.0, 1.0
    a0[3, 3], a0[4, 4] = -1 / RN, -1 / RB
    a, b = np.linalg.solve(m, a0), np.linalg.solve(m, b0)
    lam, v = np.linalg.eig(a)
    res = v[4][:, None] * np.linalg.solve(v, b)  # C V (sI - Lambda)^-1 V^-1 B
    return RationalModel(lam, res[:, None, :], kind="H")


def pwm_breakpoints(n: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """PWL corners of three 130 V PWM phases (8 kHz, duties 0.5/0.3/0.7, t_r 50 ns,
    t_f 26 ns), all on the 10 ns sample grid so that sampling the PWL loses nothing."""
    out = []
    period = 12_500  # samples (8 kHz at 100 MS/s)
    for ph, duty in enumerate((0.5, 0.3, 0.7)):
        t, v = [0], [0.0]
        k = 0
        while True:
            on = k * period + int((0.5 - duty / 2) * period) + 100 * ph + 50
            off = k * period + int((0.5 + duty / 2) * period) + 100 * ph + 50
            if off + 3 >= n:
                break
            t += [on, on + 5, off, off + 3]  # 50 ns rise, 30 ns fall
            v += [0.0, 130.0, 130.0, 0.0]
            k += 1
        out.append((np.array(t, float) / FS, np.array(v)))
    return out


def netlist(bps: list[tuple[np.ndarray, np.ndarray]]) -> str:
    """ngspice netlist of the three-phase bearing network driven by PWL sources."""
    lines = ["* three-phase RLC bearing network"]
    for k, name in enumerate("UVW"):
        t, v = bps[k]
        pts = " ".join(f"{a:.12g} {b:.12g}" for a, b in zip(t, v, strict=True))
        lines += [f"V{name} {name} 0 PWL({pts})", f"R{name} {name} {name}m {R[k]}",
                  f"L{name} {name}m N {L[k]}"]
    lines += [f"CN N 0 {CN}", f"RN N 0 {RN}", f"CWR N B {CWR}", f"CB B 0 {CB}", f"RB B 0 {RB}"]
    return "\n".join(lines)
