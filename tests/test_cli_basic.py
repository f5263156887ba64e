"""CLI: --help, info and convert on valid input."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import skrf

from vfmodel.cli.main import main


def test_help_exit_0(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--help"]) == 0
    assert "convert" in capsys.readouterr().out
    for cmd in ("info", "convert"):
        assert main([cmd, "--help"]) == 0


def test_console_script_runs() -> None:
    out = subprocess.run([sys.executable, "-m", "vfmodel.cli.main", "--version"],
                         capture_output=True, text=True, check=True)
    assert "vfmodel" in out.stdout


def test_convert_s4p_to_z_csv_matches_scikit_rf(tmp_path: Path, agilent: Path) -> None:
    out = tmp_path / "z.csv"
    assert main(["convert", str(agilent), str(out), "--kind", "Z"]) == 0
    header = out.read_text().splitlines()[0].split(",")
    assert header[:3] == ["frequency_hz", "z1_1_real", "z1_1_imag"]
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    z11 = table[:, 1] + 1j * table[:, 2]
    ref = skrf.Network(str(agilent)).z[:, 0, 0]
    assert np.max(np.abs(z11 - ref) / np.abs(ref)) < 1e-12


def test_info_json(tiny_dataset: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", str(tiny_dataset), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert set(s["impedance"]) == {"U-Frame", "V-Frame", "U-V"}
    assert s["impedance"]["U-Frame"]["n_points"] == 301
    assert s["impedance"]["U-Frame"]["f_min_hz"] == pytest.approx(1e3, rel=1e-12)
    rec = s["recordings"]
    assert [r["speed_rpm"] for r in rec] == [0.0, 100.0]
    assert rec[0]["fs_hz"] == pytest.approx(100e6, rel=1e-12)
    assert rec[0]["duration_s"] == pytest.approx(4096 / 100e6, rel=1e-12)
    # the generator adds complex noise of relative std 0.5 % * sqrt(2) = 0.707 %
    for topo in ("U-Frame", "V-Frame", "U-V"):
        assert s["impedance"][topo]["noise_pct"] == pytest.approx(0.707, rel=0.2)
