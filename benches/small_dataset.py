"""Small synthetic datasets for examples and tests (deterministic from a seed).

`make_small_dataset` writes a dataset in the CONTRACT layout whose impedances are analytic
(series R-L-C branches) and whose recordings are three PWM-like terminal voltages and a
bearing voltage made by a capacitive divider of the common-mode voltage, with noise.
It is a quick stand-in for real data; the virtual test bench of the grey-box model
(``scripts/make_testbench.py``) is the realistic one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from vfmodel.core.atomic import atomic_path, atomic_write_text
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.io_spectrum import write_spectrum


def series_rlc(freq_hz: NDArray[np.float64], r_ohm: float, l_h: float,
               c_f: float) -> NDArray[np.complex128]:
    """Impedance of a series R-L-C branch."""
    s = 2j * np.pi * freq_hz
    z: NDArray[np.complex128] = r_ohm + s * l_h + 1.0 / (s * c_f)
    return z


def pwm_terminals(n_samples: int, fs: float, f_sw: float = 8e3, v_dc: float = 270.0,
                  t_rise: float = 50e-9) -> NDArray[np.float64]:
    """Three phase-to-frame voltages of a two-level inverter (sine-triangle PWM, 0.8
    modulation), edges with a finite rise time, relative to the DC-link midpoint."""
    t = np.arange(n_samples) / fs
    phases = np.array([0.0, -2 * np.pi / 3, 2 * np.pi / 3])[:, None]
    ref = 0.8 * np.sin(2 * np.pi * 50.0 * t[None, :] + phases)
    tri = 2 * np.abs(2 * ((t * f_sw) % 1.0) - 1) - 1
    sw = np.where(ref > tri[None, :], 0.5, -0.5) * v_dc
    # finite slew: moving average over the rise time
    k = max(1, round(t_rise * fs))
    kernel = np.ones(k) / k
    return np.stack([np.convolve(row, kernel, mode="same") for row in sw])


def make_small_dataset(root: str | Path, seed: int = 0, n_samples: int = 8192,
                       fs: float = 100e6) -> Path:
    """Write a small dataset (two CM spectra, one DM spectrum, recordings at 0 and 100 rpm)."""
    root = Path(root)
    rng = np.random.default_rng(seed)
    f = np.logspace(3, 7, 301)
    spectra = {
        "U-Frame": series_rlc(f, 8.0, 4e-6, 2.0e-9),
        "V-Frame": series_rlc(f, 8.5, 4.1e-6, 1.9e-9),
        "U-V": series_rlc(f, 0.5, 1e-3, 1e-10),
    }
    entries = []
    for topo, z in spectra.items():
        noisy = z * (1 + 0.005 * (rng.normal(size=z.size) + 1j * rng.normal(size=z.size)))
        rel = f"impedance/{topo}.csv"
        write_spectrum(root / rel, FrequencyData(f, noisy, "Z"))
        entries.append(f'"{topo}" = "{rel}"')
    u = pwm_terminals(n_samples, fs)
    recs = []
    for speed, bvr in ((0.0, 0.002), (100.0, 0.016)):
        terms = u + rng.normal(0, 0.5, u.shape)
        u_b = bvr * u.mean(axis=0) + rng.normal(0, 0.05, n_samples)
        rel = f"recordings/rpm{int(speed):04d}.npz"
        (root / "recordings").mkdir(parents=True, exist_ok=True)
        with atomic_path(root / rel) as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(fh, u_U=terms[0], u_V=terms[1], u_W=terms[2], u_B=u_b, fs=fs)
        recs.append(f'[[recording]]\nspeed_rpm = {speed}\nfile = "{rel}"\n')
    toml = (
        'name = "small-example"\n'
        'description = "analytic R-L-C spectra and a capacitive-divider bearing voltage"\n'
        "temperature_c = 80.0\n\n[impedance]\n" + "\n".join(entries) + "\n\n" + "\n".join(recs)
    )
    atomic_write_text(root / "dataset.toml", toml)
    return root
