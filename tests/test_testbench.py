"""Virtual test bench: dataset validity, paper magnitudes, noise levels, steady state, seed."""

from __future__ import annotations

import json
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

import vfmodel
from benches.truth import (
    build_truth_network,
    lubricant_at_speed,
    truth_detail,
    truth_params,
)
from tests.conftest import load_script
from vfmodel.greybox.drive import CableSpec, InverterSpec, ScopeSpec, edge_spectrum, steady_state
from vfmodel.pipeline.summary import spectrum_noise_pct

ROOT = Path(__file__).resolve().parents[1]


def _script() -> ModuleType:
    return load_script("make_testbench")


_FAST = {"n_coils": 2, "n_rungs": 4}   # smaller truth network for the tests


@pytest.fixture(scope="module")
def bench(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("tb") / "b0"
    _script().make_bench(out, seed=3, speeds=(0.0, 100.0), periods=2, n_freq=301, **_FAST)
    return out


def test_bench_reads_and_has_paper_magnitudes(bench: Path) -> None:
    ds = vfmodel.read_dataset(bench)
    assert sorted(ds.impedance) == sorted(["U-Frame", "V-Frame", "W-Frame", "U-V", "V-W", "W-U"])
    assert [r.speed_rpm for r in ds.recordings] == [0.0, 100.0]
    truth = json.loads((bench / "truth.json").read_text())
    for r in ds.recordings:
        assert r.fs == 100e6 and r.n_samples == 25000        # 2 PWM periods at 100 MS/s
        assert np.abs(r.terminals).max() > 130.0               # paper: inputs exceed 130 V
    rec = truth["recordings"]
    # paper: ~0.6 V peak at 0 rpm (metallic contact), ~3.04 V at 100 rpm; +-25 %
    assert 0.45 < rec["0"]["peak_u_b_clean_v"] < 0.75
    assert 2.3 < rec["100"]["peak_u_b_clean_v"] < 3.8
    # paper Table IV: C_wr 637 pF, C_rf 1287 pF, BVR 1.62 % at 100 rpm; +-15 %
    d = truth["divider"]
    assert abs(d["c_wr"] / 637e-12 * 1 / (1 + truth["truth_params"]["insulation.k_d"]) - 1) < 0.15
    assert abs(d["bvr"] / 0.0162 - 1) < 0.15
    # SNR by construction (definition in vfmodel.greybox.drive): 35 dB inputs, 1.3 dB u_B at 0 rpm
    assert abs(rec["0"]["snr_terminal_db"] - 35.0) < 0.3
    assert abs(rec["0"]["snr_u_b_db"] - 1.3) < 0.3
    assert rec["100"]["snr_u_b_db"] > 20.0


def test_bench_cm_impedance_capacitive_with_resonances(bench: Path) -> None:
    ds = vfmodel.read_dataset(bench)
    for topo, d in ds.impedance.items():
        # 0.5 % complex noise; the median estimator over ~300 points has a relative
        # standard deviation ~ 2/sqrt(300)/ln2/2 = 8 %: 3 sigma = +-0.125 %
        assert 0.375 < spectrum_noise_pct(d) < 0.625, topo
    z = ds.impedance["U-Frame"].values[:, 0, 0]
    f = ds.impedance["U-Frame"].freq_hz
    # capacitive at 1 kHz: phase below -85 deg, C = -1/(w Im Z) a few nF
    assert np.angle(z[0], deg=True) < -85 and 3e-9 < -1 / (2 * np.pi * f[0] * z[0].imag) < 8e-9
    # resonance (minimum of |Z|) between 100 kHz and 10 MHz
    assert 1e5 < f[np.argmin(np.abs(z))] < 1e7


def test_bench_is_deterministic_from_seed(bench: Path, tmp_path: Path) -> None:
    mod = _script()
    mod.make_bench(tmp_path / "same", seed=3, speeds=(0.0, 100.0), periods=2, n_freq=301,
                   **_FAST)
    mod.make_bench(tmp_path / "other", seed=4, speeds=(0.0, 100.0), periods=2, n_freq=301,
                   **_FAST)
    for name in ("recordings/rpm0000.npz", "recordings/rpm0100.npz", "impedance/U-V.csv"):
        a = (bench / name).read_bytes()
        assert a == (tmp_path / "same" / name).read_bytes()
        assert a != (tmp_path / "other" / name).read_bytes()


def test_steady_state_is_periodic() -> None:
    # standstill: the PWM pattern repeats every carrier period, so the steady state of a
    # 2-period record is the 1-period record twice (a zero-initial-state simulation is not)
    rng = np.random.default_rng(0)
    p, st = lubricant_at_speed(truth_params(), 0.0)
    net = build_truth_network(p, truth_detail(rng, n_coils=2, n_rungs=3), state=st)
    y1 = steady_state(net, InverterSpec(), CableSpec(), ScopeSpec(n_periods=1), 0.0)
    y2 = steady_state(net, InverterSpec(), CableSpec(), ScopeSpec(n_periods=2), 0.0)
    n = y1.shape[1]
    scale = np.abs(y1).max(axis=1, keepdims=True)
    assert np.max(np.abs(y2[:, :n] - y1) / scale) < 1e-9
    assert np.max(np.abs(y2[:, n:] - y1) / scale) < 1e-9


def test_edge_spectrum_matches_trapezoid() -> None:
    # the band-limited (harmonics < fs/2) trapezoid differs from the sampled one by the
    # series tail at each slope kink: sum_{|n|>N} s/(2 pi n)^2 T ~ s / (2 pi^2 f_N) with the
    # slope s = dV/dur (the 2-us rise here), and the mean is exact
    fs, n = 10e6, 1000
    t = np.arange(n) / fs
    rise, fall, dr, df = np.array([20e-6]), np.array([60e-6]), 2e-6, 3e-6
    x = np.fft.irfft(edge_spectrum(rise, fall, -1.0, 2.0, dr, df, n / fs, n, fs), n)
    ref = -1.0 + 3.0 * (np.clip((t - rise[0]) / dr, 0, 1) - np.clip((t - fall[0]) / df, 0, 1))
    bound = 3.0 / dr / (2 * np.pi**2 * fs / 2)
    assert np.max(np.abs(x - ref)) < 1.05 * bound
    assert abs(x.mean() - ref.mean()) < 1e-9
