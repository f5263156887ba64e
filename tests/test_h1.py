"""MIMO H1 estimator: scipy.signal.csd reference, noisy 3-input system, bad input, BVR."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest
import scipy.signal as ss

import vfmodel
from vfmodel import RationalModel
from vfmodel.errors import IllConditionedWarning, InputError, SignalWarning
from vfmodel.greybox.bearing import bvr
from vfmodel.signals.h1 import h1_analysis, h1_analysis_blocks
from vfmodel.signals.simulate import discrete_transfer, simulate_periodic

FS = 100e6
# three known discrete-time systems (b, a): inputs U, V, W -> bearing voltage
SYSTEMS = [([0.02, 0.01], [1, -1.6, 0.81]), ([0.015], [1, -0.9]), ([0.04, 0.005], [1, -1.2, 0.5])]


def pwm_inputs(n: int, rng: np.random.Generator) -> np.ndarray:
    """Three PWM-like phase voltages (random PWM: carrier period 64-192 samples and duty
    drawn per period, independently per phase), 8-sample edges, ringing, 130 V level."""
    out = np.empty((3, n))
    for k in range(3):
        periods = rng.integers(64, 193, n // 64 + 2)
        duty = rng.uniform(0.1, 0.9, periods.size)
        on = np.concatenate([np.arange(p) < d * p for p, d in zip(periods, duty, strict=True)])
        sq = on[:n].astype(float)
        sq = np.convolve(sq, np.ones(8) / 8, mode="same")  # finite rise time
        out[k] = 130 * ss.lfilter([0.3], [1, -1.4, 0.7], sq)  # overshoot ringing
    return out


def true_h(freq: np.ndarray) -> np.ndarray:
    return np.stack([ss.freqz(b, a, worN=freq, fs=FS)[1] for b, a in SYSTEMS], axis=1)


def output_of(x: np.ndarray) -> np.ndarray:
    return sum(ss.lfilter(b, a, x[k]) for k, (b, a) in enumerate(SYSTEMS))


def test_agrees_with_scipy_csd_on_clean_data() -> None:
    rng = np.random.default_rng(0)
    x = pwm_inputs(2**15, rng)
    y = output_of(x)
    res = h1_analysis(x, y, FS, nperseg=1024, noverlap=256, window="hann")
    gxx = np.empty((513, 3, 3), complex)
    gyx = np.empty((513, 3), complex)
    for i in range(3):
        for j in range(3):
            _, gxx[:, i, j] = ss.csd(x[j], x[i], FS, nperseg=1024, noverlap=256)
        _, gyx[:, i] = ss.csd(x[i], y, FS, nperseg=1024, noverlap=256)
    h_ref = np.linalg.solve(np.conj(gxx[1:]), gyx[1:, :, None])[:, :, 0]
    coh_ref = np.real(np.sum(h_ref * np.conj(gyx[1:]), axis=1)) / np.real(
        ss.csd(y, y, FS, nperseg=1024, noverlap=256)[1][1:])
    assert np.max(np.abs(res.gxx - gxx)) < 1e-10 * np.max(np.abs(gxx))
    assert np.max(np.abs(res.gyx[:, 0] - gyx)) < 1e-10 * np.max(np.abs(gyx))
    # H relative to the largest |H_j| of each input (rounding x cond(G_xx) near zeros of H)
    h_scale = np.max(np.abs(h_ref), axis=0)
    assert np.max(np.abs(res.h[1:, 0] - h_ref) / h_scale) < 1e-10
    assert np.max(np.abs(res.coherence[1:, 0] - coh_ref)) < 1e-10
    # contract form
    _f, h, coh = vfmodel.h1_estimate(x, y, FS, nperseg=1024, noverlap=256)
    assert h.shape == (513, 3) and coh.shape == (513,)
    assert np.max(np.abs(h[1:] - h_ref) / h_scale) < 1e-10


@pytest.mark.parametrize("snr_db", [0.0, 1.3, 3.0])
def test_noisy_three_input_system(snr_db: float) -> None:
    rng = np.random.default_rng(int(10 * snr_db) + 1)
    n = 2**21
    x = pwm_inputs(n, rng)
    y0 = output_of(x)
    p_sig = np.var(y0)
    y = y0 + rng.normal(0, np.sqrt(p_sig / 10 ** (snr_db / 10)), n)
    snr = 10 * np.log10(p_sig / np.var(y - y0))
    assert abs(snr - snr_db) < 0.05
    res = h1_analysis(x, y, FS, nperseg=2048)
    ok = res.coherence[:, 0] > 0.9
    assert ok.sum() >= 20  # the check below covers a real band
    h_true = true_h(res.freq_hz[ok])
    err_mag = np.abs(np.abs(res.h[ok, 0]) / np.abs(h_true) - 1)
    err_ph = np.degrees(np.abs(np.angle(res.h[ok, 0] / h_true)))
    assert err_mag.max() < 0.03
    assert err_ph.max() < 3.0
    # uncertainty estimate is calibrated: |H1 - H|^2 / h_std^2 ~ Exp(1); the mean of the
    # ~90 values has a standard deviation of ~0.1, so [0.6, 1.5] is a > 4-sigma band
    ratio = np.abs(res.h[ok, 0] - h_true) ** 2 / res.h_std[ok, 0] ** 2
    assert 0.6 < ratio.mean() < 1.5


def test_streamed_blocks_equal_whole_record() -> None:
    rng = np.random.default_rng(3)
    x = pwm_inputs(50_000, rng)
    y = output_of(x) + rng.normal(0, 1.0, x.shape[1])
    z = np.vstack([x, y])
    cuts = [0, 1234, 1235, 20000, 33333, 50_000]
    blocks = [z[:, a:b].astype(np.float32) for a, b in itertools.pairwise(cuts)]
    ref = h1_analysis(z[:3].astype(np.float32), z[3].astype(np.float32), FS, nperseg=1000,
                      noverlap=300)
    res = h1_analysis_blocks(blocks, FS, n_in=3, nperseg=1000, noverlap=300)
    assert res.n_averages == ref.n_averages == (50_000 - 1000) // 700 + 1
    assert np.nanmax(np.abs(res.h - ref.h) / np.abs(ref.h)) < 1e-12


def test_pure_common_mode_warns_and_bvr_recovers_cm_transfer() -> None:
    rng = np.random.default_rng(4)
    u = pwm_inputs(2**16, rng)[0]
    x = np.stack([u, u, u])
    y = output_of(x)
    with pytest.warns(IllConditionedWarning, match="common-mode"):
        res = h1_analysis(x, y + rng.normal(0, 0.01, y.size), FS, nperseg=2048)
    assert np.all(np.isnan(res.h[~res.valid]))
    assert res.valid.sum() == 0
    b = bvr(u, u, u, y, FS, nperseg=2048)
    ok = b.coherence > 0.99
    h_cm = true_h(b.freq_hz[ok]).sum(axis=1)  # u_CM = u: transfer is the sum
    assert ok.sum() > 100
    assert np.max(np.abs(b.bvr[ok] / h_cm - 1)) < 0.01


def test_bvr_ratio_equals_transfer_for_periodic_record() -> None:
    # paper eq. 3 on a periodic (circular) record: U_b / U_CM is exactly H_cm at each bin
    rng = np.random.default_rng(5)
    x = pwm_inputs(4096, rng)
    model = RationalModel([-2e6 + 2e7j, -2e6 - 2e7j, -5e5], np.array([1e6 + 1e5j, 1e6 - 1e5j,
                          3e5])[:, None, None], kind="H")
    cm = x.mean(axis=0)
    yb = simulate_periodic(model, cm[None, :], FS)[0]
    b = bvr(x[0], x[1], x[2], yb, FS, method="ratio")
    ref = discrete_transfer(model, FS, 4096)[:, 0, 0]
    big = np.abs(np.fft.rfft(cm)) > 1e-6 * np.abs(np.fft.rfft(cm)).max()
    big[-1] = False  # Nyquist bin of a real signal is real: H there is not observable
    assert np.max(np.abs(b.bvr[big] / ref[big] - 1)) < 1e-9


def test_bad_recordings_name_the_channel() -> None:
    rng = np.random.default_rng(6)
    x = pwm_inputs(4096, rng)
    y = output_of(x)
    names: dict[str, Any] = dict(input_names=["u_U", "u_V", "u_W"], output_names=["u_B"])
    xn = x.copy()
    xn[1, 100] = np.nan
    with pytest.raises(InputError, match=r"u_V.*NaN"):
        h1_analysis(xn, y, FS, nperseg=256, **names)
    with pytest.raises(InputError, match=r"u_W.*4000 samples"):
        h1_analysis([x[0], x[1], x[2][:4000]], y, FS, nperseg=256, **names)
    with pytest.raises(InputError, match=r"u_B.*different lengths"):
        h1_analysis(x, y[:-1], FS, nperseg=256, **names)
    with pytest.raises(InputError, match=r"u_U.*4096 samples.*nperseg=8192"):
        h1_analysis(x, y, FS, nperseg=8192, **names)
    noisy = y + rng.normal(0, 0.05, y.size)
    clipped = np.clip(noisy, None, np.percentile(noisy, 95))
    with pytest.warns(SignalWarning, match=r"'u_B' looks clipped"):
        h1_analysis(x, clipped, FS, nperseg=256, **names)
