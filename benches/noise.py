"""Acquisition noise of the virtual test benches: white noise plus EMI above 10 MHz.

White Gaussian noise plus EMI above 10 MHz (continuous tones and damped bursts at every
switching edge of the drive, identical phase in all channels). The SNR of a channel is
``10 log10(var(clean) / mean(noise^2))`` over the stored (full-band) record.

References
----------
Reference paper (grey-box bearing-voltage model of a 40-kW PMSM), Sec. II-C: EMI above
10 MHz, input SNR 35.1 dB, bearing-voltage SNR 1.28 dB at 0 rpm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vfmodel.greybox.drive import InverterSpec, ScopeSpec, pwm_edges

__all__ = ["Emi", "add_noise", "make_emi", "snr_db"]

ArrF = NDArray[np.float64]


@dataclass(frozen=True)
class Emi:
    """EMI waveform (n_samples,) of unit RMS, shared by all channels (scaled per channel)."""

    wave: ArrF


def make_emi(rng: np.random.Generator, inv: InverterSpec, scope: ScopeSpec, speed_rpm: float,
             n_tones: int = 4, burst_tau_s: float = 150e-9) -> Emi:
    """Unit-RMS EMI above 10 MHz: ``n_tones`` continuous tones and damped bursts at edges."""
    n = round(scope.n_periods * scope.fs_hz / inv.f_sw_hz)
    t = np.arange(n) / scope.fs_hz
    lo, hi = scope.emi_band_hz
    tones = np.zeros(n)
    for _ in range(n_tones):
        tones += rng.uniform(0.5, 1.0) * np.sin(2 * np.pi * rng.uniform(lo, hi) * t
                                                + rng.uniform(0, 2 * np.pi))
    bursts = np.zeros(n)
    f_b = rng.uniform(lo, hi)
    for r, fl in pwm_edges(inv, speed_rpm, scope.n_periods):
        for t0 in np.concatenate([r, fl]):
            k0 = int(np.ceil(t0 * scope.fs_hz))
            k1 = min(n, k0 + int(8 * burst_tau_s * scope.fs_hz))
            tt = t[k0:k1] - t0
            bursts[k0:k1] += np.exp(-tt / burst_tau_s) * np.sin(2 * np.pi * f_b * tt)
    tones /= np.sqrt(np.mean(tones**2))
    bursts /= np.sqrt(np.mean(bursts**2))
    w = tones + bursts
    return Emi(w / np.sqrt(np.mean(w**2)))


def add_noise(clean: ArrF, noise_rms: ArrF, emi: Emi, emi_fraction: float,
              rng: np.random.Generator) -> ArrF:
    """``clean`` (n_ch, n) plus noise of RMS ``noise_rms`` per channel; a fraction
    ``emi_fraction`` of the noise power is the shared EMI, the rest independent white noise."""
    rms = np.asarray(noise_rms, dtype=float)[:, None]
    white = rng.standard_normal(clean.shape) * rms * np.sqrt(1 - emi_fraction)
    sign = rng.choice([-1.0, 1.0], size=(clean.shape[0], 1))
    return clean + white + sign * rms * np.sqrt(emi_fraction) * emi.wave[None, :]


def snr_db(clean: ArrF, noisy: ArrF) -> ArrF:
    """Per channel ``10 log10(var(clean) / mean((noisy - clean)^2))``."""
    c = np.atleast_2d(clean)
    nz = np.atleast_2d(noisy) - c
    return np.asarray(10 * np.log10(np.var(c, axis=1) / np.mean(nz**2, axis=1)), dtype=float)
