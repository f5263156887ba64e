"""Spectrum files: round trips to 1e-9 and agreement with scikit-rf's reader."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import skrf

from tests.conftest import TOUCHSTONE_DIR, rlc_impedance
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.io_spectrum import read_spectrum, write_spectrum


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def test_csv_touchstone_csv_round_trip(tmp_path: Path) -> None:
    f = np.logspace(3, 7, 301)
    orig = FrequencyData(f, rlc_impedance(f), "Z")
    write_spectrum(tmp_path / "a.csv", orig)
    a = read_spectrum(tmp_path / "a.csv")
    write_spectrum(tmp_path / "b.s1p", a)
    b = read_spectrum(tmp_path / "b.s1p")
    write_spectrum(tmp_path / "c.csv", b)
    c = read_spectrum(tmp_path / "c.csv")
    assert c.kind == "Z"
    assert _rel(c.freq_hz, f) < 1e-12
    assert np.max(np.abs(c.values - orig.values) / np.abs(orig.values)) < 1e-9


@pytest.mark.parametrize("name", ["Agilent_E5071B.s4p", "cst_example_4ports.s4p"])
def test_touchstone_csv_touchstone_round_trip(tmp_path: Path, name: str) -> None:
    orig = read_spectrum(TOUCHSTONE_DIR / name)
    ref = skrf.Network(str(TOUCHSTONE_DIR / name))
    assert _rel(orig.values, ref.s) < 1e-15  # our reader returns what scikit-rf reads
    write_spectrum(tmp_path / "x.csv", orig)
    write_spectrum(tmp_path / "y.s4p", read_spectrum(tmp_path / "x.csv"))
    back = read_spectrum(tmp_path / "y.s4p")
    assert back.kind == "S" and back.z0 == orig.z0
    assert _rel(back.values, orig.values) < 1e-9
    assert _rel(back.freq_hz[1:], orig.freq_hz[1:]) < 1e-12


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_z_touchstone_read_back_by_scikit_rf(tmp_path: Path, n: int) -> None:
    rng = np.random.default_rng(n)
    z = rng.normal(size=(9, n, n)) + 1j * rng.normal(size=(9, n, n)) + 10 * np.eye(n)
    data = FrequencyData(np.linspace(1e3, 1e6, 9), z, "Z")
    path = tmp_path / f"z.s{n}p"
    write_spectrum(path, data)
    net = skrf.Network(str(path))
    assert _rel(net.z, z) < 1e-12
    assert _rel(read_spectrum(path).values, z) < 1e-12


def test_mag_phase_csv(tmp_path: Path) -> None:
    f = np.array([1e3, 1e4, 1e5])
    z = rlc_impedance(f)
    rows = "\n".join(
        f"{fi:.17g},{abs(zi):.17g},{np.degrees(np.angle(zi)):.17g}"
        for fi, zi in zip(f, z, strict=True)
    )
    (tmp_path / "m.csv").write_text("frequency_hz,z_mag_ohm,z_phase_deg\n" + rows + "\n")
    got = read_spectrum(tmp_path / "m.csv").values[:, 0, 0]
    assert np.max(np.abs(got - z) / np.abs(z)) < 1e-12


def test_generic_csv_h_data(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    h = rng.normal(size=(4, 1, 3)) + 1j * rng.normal(size=(4, 1, 3))
    d = FrequencyData(np.arange(1.0, 5.0), h, "H")
    write_spectrum(tmp_path / "h.csv", d)
    back = read_spectrum(tmp_path / "h.csv")
    assert back.kind == "H" and back.values.shape == (4, 1, 3)
    assert _rel(back.values, h) < 1e-15
