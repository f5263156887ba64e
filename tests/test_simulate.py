"""simulate / simulate_periodic / simulate_blocks against exact references."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.linalg as sl
import scipy.signal as ss

import vfmodel
from vfmodel import RationalModel
from vfmodel.errors import InputError
from vfmodel.signals.filters import brickwall_filter
from vfmodel.signals.simulate import simulate, simulate_blocks, simulate_periodic

FS = 1e8


def mimo_model(slow_pole: float = -10.0) -> RationalModel:
    """2 outputs, 3 inputs: a resonance, a very slow pole (tau = 0.1 s >> record), a fast
    real pole, a pole so fast that its powers underflow, and a D term."""
    rng = np.random.default_rng(1)
    p = np.array([-1e5 + 2e7j, -1e5 - 2e7j, slow_pole, -3e6, -2e10])
    r = np.zeros((5, 2, 3), complex)
    r[0] = (rng.normal(size=(2, 3)) + 1j * rng.normal(size=(2, 3))) * 1e6
    r[1] = np.conj(r[0])
    r[2] = rng.normal(size=(2, 3)) * 10
    r[3] = rng.normal(size=(2, 3)) * 1e6
    r[4] = rng.normal(size=(2, 3)) * 1e9
    return RationalModel(p, r, d=rng.normal(size=(2, 3)), kind="H")


def pwl_inputs(n: int, seed: int = 2) -> np.ndarray:
    x = np.cumsum(np.random.default_rng(seed).normal(size=(3, n)), axis=1)
    return x - x[:, :1]  # start at 0 V (zero initial state, as SPICE with a 0 V source)


def lsim_foh(model: RationalModel, x: np.ndarray, x0: np.ndarray | None = None) -> np.ndarray:
    """scipy's lsim: exact state-space response to linearly interpolated inputs."""
    s = model.to_state_space()
    t = np.arange(x.shape[1]) / FS
    _, y, _ = ss.lsim((s.a, s.b, s.c, s.d), x.T, t, X0=x0)
    return np.atleast_2d(y.T) if y.ndim > 1 else y[None, :]


@pytest.mark.parametrize("fft_len", [2**20, 2**12, 1024])
def test_linear_input_model_is_exact_vs_lsim(fft_len: int) -> None:
    m = mimo_model()
    x = pwl_inputs(20_000)
    y = simulate(m, x, FS, input_model="linear", fft_len=fft_len)
    ref = lsim_foh(m, x)
    assert y.shape == (2, 20_000)
    # streaming in blocks of 1024 with the slow pole carried as state: still exact
    assert np.max(np.abs(y - ref)) < 1e-10 * np.max(np.abs(ref))


def test_streamed_blocks_equal_one_shot() -> None:
    m = mimo_model()
    # band-limited input (oscilloscope record after the 10 MHz filter)
    x = brickwall_filter(pwl_inputs(30_000, seed=3), FS, 10e6)
    cuts = [0, 7, 5000, 5001, 17_000, 30_000]

    def blocks() -> list[np.ndarray]:
        return [x[:, a:b] for a, b in itertools.pairwise(cuts)]

    ref = simulate(m, x, FS, input_model="linear")
    out = np.concatenate(list(simulate_blocks(m, blocks(), FS, n_in=3, fft_len=2**12,
                                              input_model="linear")), axis=1)
    assert out.shape == ref.shape
    assert np.max(np.abs(out - ref)) < 1e-10 * np.max(np.abs(ref))  # exact either way
    ref = simulate(m, x, FS)
    out = np.concatenate(list(simulate_blocks(m, blocks(), FS, n_in=3, fft_len=2**14)), axis=1)
    # band-limited mode: the short band-limited correction (1/n tails from the jump of H
    # at fs/2) is truncated at margin = pad = 2048 samples around each block; measured
    # 2.2e-5 of the peak here
    assert np.max(np.abs(out - ref)) < 1e-4 * np.max(np.abs(ref))


def test_derivative_term_is_central_difference_in_linear_mode() -> None:
    e = np.array([[2e-9]])
    m = RationalModel(np.zeros(0), np.zeros((0, 1, 1)), d=np.zeros((1, 1)), e=e, kind="Z")
    x = pwl_inputs(1000)[:1]
    y = simulate(m, x, FS, input_model="linear")[0]
    xp = np.concatenate([[0.0], x[0], [0.0]])
    ref = 2e-9 * (xp[2:] - xp[:-2]) * FS / 2
    assert np.max(np.abs(y - ref)) < 1e-9 * np.max(np.abs(ref))
    # band-limited: the spectral derivative, exact for a periodic band-limited tone
    n = 1000
    tone = np.sin(2 * np.pi * 37 * np.arange(n) / n)
    yp = simulate_periodic(m, tone[None, :], FS)[0]
    ref_p = 2e-9 * 2 * np.pi * 37 * FS / n * np.cos(2 * np.pi * 37 * np.arange(n) / n)
    assert np.max(np.abs(yp - ref_p)) < 1e-9 * np.max(np.abs(ref_p))


def test_periodic_steady_state_with_slow_pole_matches_state_space() -> None:
    # PWM period of 2000 samples, pole time constant 1000 periods: periodic steady state
    m = mimo_model(slow_pole=-50.0)
    n = 2000
    x = np.zeros((3, n))
    x[0, 200:900] = 1.0
    x[1, 600:1500] = -1.0
    x[2] = np.linspace(0, 1, n) ** 2
    y = simulate_periodic(m, x, FS, input_model="linear")
    # reference: state after one period from zero (input closed periodically), then the
    # initial state x0 with x0 = Ad^n x0 + x_1  ->  x0 = (I - Ad^n)^-1 x_1
    s = m.to_state_space()
    xc = np.concatenate([x, x[:, :1]], axis=1)
    t = np.arange(n + 1) / FS
    _, _, st = ss.lsim((s.a, s.b, s.c, s.d), xc.T, t)
    x0 = np.linalg.solve(np.eye(s.a.shape[0]) - sl.expm(s.a * n / FS), st[-1])
    _, ref, _ = ss.lsim((s.a, s.b, s.c, s.d), xc.T, t, X0=x0)
    ref = ref[:-1].T
    assert np.max(np.abs(y - ref)) < 1e-8 * np.max(np.abs(ref))


def test_callable_model_matches_rational_model() -> None:
    fast = RationalModel([-2e6 + 3e7j, -2e6 - 3e7j, -5e6],
                         np.array([1e7 + 2e6j, 1e7 - 2e6j, 4e6])[:, None, None].repeat(3, 2),
                         d=np.full((1, 3), 0.1), kind="H")
    x = pwl_inputs(10_000)
    ref = vfmodel.simulate(fast, x, FS)
    y = simulate(lambda f: fast(f), x, FS, pad=4096)
    # the callable's impulse response decays (tau = 0.5 us = 50 samples) within pad
    assert np.max(np.abs(y - ref)) < 1e-6 * np.max(np.abs(ref))


def test_bad_inputs() -> None:
    m = mimo_model()
    x = pwl_inputs(100)
    unstable = RationalModel([1e3], np.ones((1, 1, 1)), kind="H")
    with pytest.raises(InputError, match="not stable"):
        simulate(unstable, x[:1], FS)
    with pytest.raises(InputError, match="2 channels"):
        simulate(m, x[:2], FS)
    with pytest.raises(InputError, match="needs a RationalModel"):
        simulate(lambda f: m(f), x, FS, input_model="linear")
    xn = x.copy()
    xn[2, 5] = np.inf
    with pytest.raises(InputError, match=r"inputs\[2\].*index 5"):
        simulate(m, xn, FS)
    with pytest.raises(InputError, match="different lengths"):
        simulate(m, [x[0], x[1], x[2][:-1]], FS)


def test_very_slow_pole_matches_lsim() -> None:
    """A pole far slower than the record (time constant ~ 4 h at 100 MS/s, as a vector fit
    of an inductive path to ground produces) is exact: reference scipy.signal.lsim."""
    from scipy import signal

    from vfmodel.signals.simulate import simulate_blocks

    fs, n = 1e8, 2000
    p = np.array([-6.28e-5, -2e3 + 5e6j, -2e3 - 5e6j])
    r = np.array([1e5, 3e4 + 1e4j, 3e4 - 1e4j])
    model = RationalModel(p, r, kind="H")
    x = np.zeros((1, n))
    x[0, 100:300] = 1.0
    t = np.arange(n) / fs
    ss = model.to_state_space()
    _, y_ref, _ = signal.lsim((ss.a, ss.b, ss.c, ss.d), x[0], t)
    scale = np.max(np.abs(y_ref))
    y = simulate(model, x, fs, input_model="linear")
    assert np.max(np.abs(y[0] - y_ref)) < 1e-9 * scale
    blocks = (x[:, i : i + 300] for i in range(0, n, 300))
    yb = np.concatenate(list(simulate_blocks(model, blocks, fs, n_in=1,
                                             input_model="linear", fft_len=4096)), axis=1)
    assert np.max(np.abs(yb[0] - y_ref)) < 1e-9 * scale
