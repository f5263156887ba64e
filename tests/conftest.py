"""Shared fixtures: small datasets written to temporary directories."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.io_spectrum import write_spectrum

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
TOUCHSTONE_DIR = SHARED / "data" / "touchstone"


def rlc_impedance(freq_hz: np.ndarray, r: float = 5.0, l_h: float = 2e-6,
                  c_f: float = 1e-9) -> np.ndarray:
    """Series R-L-C impedance, analytic."""
    s = 2j * np.pi * freq_hz
    return r + s * l_h + 1 / (s * c_f)


def make_dataset(root: Path, n_samples: int = 4096, fs: float = 100e6) -> Path:
    """A small valid dataset: two CM spectra and two recordings (analytic, seeded)."""
    root.mkdir(parents=True, exist_ok=True)
    (root / "impedance").mkdir(exist_ok=True)
    (root / "recordings").mkdir(exist_ok=True)
    f = np.logspace(3, 7, 200)
    write_spectrum(root / "impedance/U-Frame.csv", FrequencyData(f, rlc_impedance(f), "Z"))
    write_spectrum(root / "impedance/V-Frame.s1p", FrequencyData(f, rlc_impedance(f, 6), "Z"))
    rng = np.random.default_rng(1)
    t = np.arange(n_samples) / fs
    for speed in (0, 100):
        u = np.sign(np.sin(2 * np.pi * 1e5 * t[None, :] + np.array([[0], [2.1], [4.2]])))
        u = 100 * u + rng.normal(0, 0.5, u.shape)
        ub = 0.05 * u.mean(axis=0) + rng.normal(0, 0.1, n_samples)
        np.savez(root / f"recordings/rpm{speed:04d}.npz", u_U=u[0], u_V=u[1], u_W=u[2],
                 u_B=ub, fs=fs)
    (root / "dataset.toml").write_text(
        'name = "tiny"\ntemperature_c = 80.0\n[impedance]\n'
        '"U-Frame" = "impedance/U-Frame.csv"\n"V-Frame" = "impedance/V-Frame.s1p"\n'
        '[[recording]]\nspeed_rpm = 0.0\nfile = "recordings/rpm0000.npz"\n'
        '[[recording]]\nspeed_rpm = 100.0\nfile = "recordings/rpm0100.npz"\n'
    )
    return root


@pytest.fixture
def tiny_dataset(tmp_path: Path) -> Path:
    return make_dataset(tmp_path / "tiny")


@pytest.fixture
def agilent(tmp_path: Path) -> Path:
    dst = tmp_path / "agilent.s4p"
    shutil.copy(TOUCHSTONE_DIR / "Agilent_E5071B.s4p", dst)
    return dst
