"""Synthesised netlists in ngspice: .ac reproduces the model, .tran agrees with simulate."""

from __future__ import annotations

import numpy as np
import pytest

from benches.random_networks import random_rlc_network
from tests.test_circuit_synthesis import fitted_like_model
from vfmodel.circuit.ngspice import run_ac, run_tran
from vfmodel.circuit.synthesis import model_to_spice
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.rational_model import RationalModel

pytestmark = pytest.mark.ngspice

# seed >= 0: a random pole-residue model shaped like a fit; seed -1: vector_fit of the port
# impedance/admittance of a random RLC network (1-port Z, 1-port Y, 3-port Y)
CASES = [(11, "Z", 1), (12, "Y", 1), (13, "Y", 3), (-1, "Z", 1), (-1, "Y", 1), (-1, "Y", 3)]


def _model(seed: int, kind: str, n: int) -> RationalModel:
    if seed >= 0:
        return fitted_like_model(np.random.default_rng(seed), n, kind)
    from vfmodel.fitting.vectfit import vector_fit

    c = random_rlc_network(np.random.default_rng(5), n_nodes=10, n_elements=24,
                           n_switches=0, n_mutual=1)
    # ports through 10 ohm (so Y stays finite at DC: no pole at s ~ 0 in the fit)
    for k, node in enumerate(("n2", "n4", "n6")):
        c = c.add_resistor(f"port{k + 1}.R", f"P{k + 1}", node, 10.0)
    f = np.logspace(2, 7, 200)
    z = c.port_impedance(f, [(f"P{k + 1}", "0") for k in range(n)])
    values = z if kind == "Z" else np.linalg.inv(z)
    model, _ = vector_fit(FrequencyData(f, values, kind=kind),  # type: ignore[arg-type]
                          order=12 if n == 1 else 16, fit_e=True)
    # the network has finitely many poles: the fit reproduces it (checked, 1e-7)
    assert np.max(np.abs(model(f) - values)) < 1e-7 * np.max(np.abs(values))
    return model


def _harness(model: RationalModel, sources: list[str]) -> str:
    """Top level: the subcircuit, its instance, one source card per port."""
    n = model.n_in
    pins = " ".join(f"p{k + 1}" for k in range(n))
    lines = ["synthesis harness", model_to_spice(model, "vfmodel").strip(),
             f"X1 {pins} 0 vfmodel", *sources]
    return "\n".join(lines) + "\n"


def _pwl(t: np.ndarray, x: np.ndarray) -> str:
    pts = [f"{a:.12g} {b:.12g}" for a, b in zip(t, x, strict=True)]
    body = "\n".join("+ " + " ".join(pts[i:i + 8]) for i in range(0, len(pts), 8))
    return "PWL(\n" + body + "\n+ )"


@pytest.mark.parametrize(("seed", "kind", "n"), CASES)
def test_synthesised_netlist_ac_matches_model(seed: int, kind: str, n: int) -> None:
    model = _model(seed, kind, n)
    worst = 0.0
    freq_ref = None
    got_all = []
    for j in range(n):
        if kind == "Z":  # unit current into p1: v(p1) = Z
            src = ["I1 0 p1 DC 0 AC 1"]
            probes = ["v(p1)"]
        else:            # unit voltage at port j, others shorted: Y[:, j] = -i(V)
            src = [f"V{k + 1} p{k + 1} 0 DC 0 AC {1 if k == j else 0}" for k in range(n)]
            probes = [f"i(V{k + 1})" for k in range(n)]
        res = run_ac(_harness(model, src), probes, f_start_hz=100.0, f_stop_hz=1e7,
                     points_per_decade=20)
        got_all.append(res.values if kind == "Z" else -res.values)
        freq_ref = res.freq_hz
    assert freq_ref is not None
    ref = model(freq_ref)
    got = np.stack(got_all, axis=2)
    # entry by entry, relative to |H_ij|; entries far below the matrix (decoupled ports of
    # the fitted network: |Y_12| ~ 1e-9 |Y| at 100 Hz, at the rounding level of any
    # realisation) are measured against 1e-6 ||H|| instead
    floor = 1e-6 * np.linalg.norm(ref, ord=2, axis=(1, 2))[:, None, None]
    worst = float(np.max(np.abs(got - ref) / np.maximum(np.abs(ref), floor)))
    assert worst < 1e-6, worst


def _smooth_pulses(t: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """Trapezoidal pulses with raised-cosine edges (50 ns), random levels and delays."""
    out = np.zeros((n, t.size))
    rise = 50e-9
    for k in range(n):
        t0 = rng.uniform(0.2e-6, 1e-6)
        width = rng.uniform(1e-6, 2e-6)

        def edge(x: np.ndarray) -> np.ndarray:
            return 0.5 - 0.5 * np.cos(np.pi * np.clip(x / rise, 0, 1))

        out[k] = rng.uniform(0.5, 1.5) * (edge(t - t0) - edge(t - t0 - width))
    return out


@pytest.mark.parametrize(("seed", "kind", "n"), CASES)
def test_synthesised_netlist_tran_matches_simulate(seed: int, kind: str, n: int) -> None:
    simulate = pytest.importorskip("vfmodel.signals.simulate").simulate
    model = _model(seed, kind, n)
    fs = 200e6
    t = np.arange(1000) / fs                    # 5 us
    u = _smooth_pulses(t, n, np.random.default_rng(seed + 1000))
    if kind == "Z":
        u = u * 1e-3                            # amperes
        src = [f"I1 0 p1 {_pwl(t, u[0])}"]
        probes = ["v(p1)"]
    else:
        src = [f"V{k + 1} p{k + 1} 0 {_pwl(t, u[k])}" for k in range(n)]
        probes = [f"i(V{k + 1})" for k in range(n)]
    # Compare at the midpoints between samples: there the derivative term s*E of a PWL
    # input is unambiguous (at a breakpoint SPICE and the sampled model may take the left,
    # right or mean slope). The PWL input is exactly linear, so simulating its 2x linear
    # upsampling is exact at the midpoints.
    res = run_tran(_harness(model, src), probes, t_step_s=0.5 / fs, t_stop_s=t[-1],
                   t_max_s=0.25 / fs)
    assert res.time_s.size == 2 * t.size - 1
    got = (res.values if kind == "Z" else -res.values)[:, 1::2]
    u2 = np.empty((n, 2 * t.size - 1))
    u2[:, ::2] = u
    u2[:, 1::2] = 0.5 * (u[:, :-1] + u[:, 1:])
    ref = simulate(model, u2, 2 * fs, input_model="linear")[:, 1::2]
    peak = np.max(np.abs(ref), axis=1)
    err = np.max(np.abs(got - ref), axis=1) / peak
    assert err.max() < 5e-3, err
