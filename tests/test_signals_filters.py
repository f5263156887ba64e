"""FFT brickwall filter, streaming FIR filter, spectral energy and edge times."""

from __future__ import annotations

import itertools
from typing import cast

import numpy as np
import pytest
import scipy.signal as ss

from vfmodel.errors import InputError
from vfmodel.signals.filters import brickwall_filter, filter_blocks, lowpass_fir
from vfmodel.signals.spectral import (
    cutoff_frequency,
    edge_times,
    energy_fraction_above,
    spectral_energy,
)

FS = 100e6


def _tones(n: int, freqs_amps: list[tuple[float, float]]) -> np.ndarray:
    t = np.arange(n) / FS
    return cast(np.ndarray,
                sum(a * np.cos(2 * np.pi * f * t + 0.3 * i) for i, (f, a) in enumerate(freqs_amps)))


def test_brickwall_keeps_below_and_removes_above_cutoff() -> None:
    # bin-exact tones (n = 10000: bin spacing 10 kHz); reference: the tones below 10 MHz
    n = 10_000
    low = _tones(n, [(1e6, 1.0), (5e6, 0.5), (9.99e6, 0.2)])
    high = _tones(n, [(12e6, 0.7), (30e6, 0.4)])
    out = brickwall_filter(np.stack([low + high, 2 * (low + high)]), FS, 10e6)
    peak = np.max(np.abs(low))
    assert np.max(np.abs(out[0] - low)) < 1e-12 * peak
    assert np.max(np.abs(out[1] - 2 * low)) < 2e-12 * peak


def test_streaming_fir_matches_brickwall_in_the_interior() -> None:
    n = 40_000
    x = _tones(n, [(1e6, 1.0), (5e6, 0.5), (9.5e6, 0.2), (12e6, 0.7), (30e6, 0.4)])
    ref = brickwall_filter(x, FS, 10e6)
    h = lowpass_fir(FS, 10e6)
    m = (h.size - 1) // 2
    sizes = [1000, 7001, 12000, 3, 19996]  # irregular blocks, sum = n
    edges = np.cumsum([0, *sizes])
    blocks = [x[None, a:b] for a, b in itertools.pairwise(edges)]
    out = np.concatenate(list(filter_blocks(blocks, FS, 10e6)), axis=1)[0]
    assert out.size == n
    # 80 dB Kaiser design: ripple 1e-4 per tone (amplitudes sum to 2.8) -> < 3e-4
    assert np.max(np.abs(out[m:-m] - ref[m:-m])) < 3e-4


def test_fir_design_meets_its_specification() -> None:
    h = lowpass_fir(FS, 10e6, transition_hz=0.5e6, atten_db=80)
    w, resp = ss.freqz(h, worN=np.linspace(0, FS / 2, 20001), fs=FS)
    mag = np.abs(resp)
    assert np.max(np.abs(mag[w <= 10e6] - 1)) < 1e-4 * 1.2  # Kaiser: ripple ~ 10^(-80/20)
    assert np.max(mag[w >= 10.5e6]) < 1e-4 * 1.2


def test_filter_blocks_names_channel_with_nan() -> None:
    blk = np.zeros((2, 1000))
    blk[1, 17] = np.nan
    with pytest.raises(InputError, match=r"u_B.*index 17"):
        list(filter_blocks([np.zeros((2, 100)), blk], FS, names=["u_U", "u_B"]))


def test_energy_fraction_above_matches_parseval() -> None:
    n = 10_000
    x = _tones(n, [(1e6, 3.0), (20e6, 0.5)]) + 7.0  # DC removed by default
    frac = energy_fraction_above(x, FS, 10e6)
    assert abs(frac[0] - 0.25 / (9 + 0.25)) < 1e-12
    se = spectral_energy(x, FS)
    assert abs(se.cumulative[0, -1] - 1) < 1e-12


def _trapezoid(fs: float, t_r: float, t_f: float, ring: float) -> np.ndarray:
    """PWM trapezoid 0..100 V with 10-90 % times t_r, t_f (0-100 % = t/0.8) and ringing
    (overshoot ``ring`` x 100 V decaying) that starts after each edge has finished."""
    t = np.arange(int(20e-6 * fs)) / fs
    v = np.zeros_like(t)
    for k in range(4):
        t_on, t_off = (1 + 5 * k) * 1e-6, (3.5 + 5 * k) * 1e-6
        d_on, d_off = t_r / 0.8, t_f / 0.8
        v += 100 * (np.clip((t - t_on) / d_on, 0, 1) - np.clip((t - t_off) / d_off, 0, 1))
        for t0, sgn in ((t_on + d_on, 1), (t_off + d_off, -1)):
            tau = t - t0
            v += np.where(tau > 0, sgn * ring * 100 * np.sin(2 * np.pi * 20e6 * tau)
                          * np.exp(-tau / 100e-9), 0.0)
    return v


def test_edge_times_of_trapezoid_with_ringing() -> None:
    fs = 1e9
    x = _trapezoid(fs, 51e-9, 26e-9, ring=0.3)
    et = edge_times(x, fs)
    assert et.rise_s.size == 4 and et.fall_s.size == 4
    # linear ramps: interpolated crossings are exact; ringing starts after the 90 % point
    assert np.max(np.abs(et.rise_s / 51e-9 - 1)) < 1e-9
    assert np.max(np.abs(et.fall_s / 26e-9 - 1)) < 1e-9
    assert abs(cutoff_frequency(et.t_rise_s, et.t_fall_s) / 1e6 - 12.2427) < 1e-3


def test_cutoff_frequency_paper_value() -> None:
    # paper eq. 2: t_r = 51 ns, t_f = 26 ns -> about 12.24 MHz
    assert abs(cutoff_frequency(51e-9, 26e-9) - 1 / (np.pi * 26e-9)) < 1e-6
    assert round(cutoff_frequency(51e-9, 26e-9) / 1e6, 2) == 12.24
    with pytest.raises(InputError):
        cutoff_frequency(0.0, 26e-9)
