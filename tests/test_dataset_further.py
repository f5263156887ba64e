"""Dataset tables beyond the paper (CONTRACT section 2a, issue 14): ``Shaft-Frame`` and
``[[impedance_at_speed]]`` spectra, the ``u_B_DE`` / ``i_CM`` channels, and the
``[machine]`` / ``[bearing]`` / ``[priors]`` tables; bad entries exit 2 naming file and key."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benches.small_dataset import make_small_dataset, series_rlc
from vfmodel._choices import TOPOLOGIES
from vfmodel.cli.main import main
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.io_dataset import read_dataset
from vfmodel.core.io_recording import read_recording, write_recording
from vfmodel.core.io_spectrum import write_spectrum
from vfmodel.errors import InputError


def run_cli(capsys: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str, str]:
    """``vfmodel argv`` in-process: exit status, stdout, stderr."""
    capsys.readouterr()
    code = main(argv)
    cap = capsys.readouterr()
    return code, cap.out, cap.err


@pytest.fixture()
def ds_root(tmp_path: Path) -> Path:
    root = make_small_dataset(tmp_path / "ds", seed=3, n_samples=1024)
    f = np.logspace(3, 7, 51)
    for name, c in (("Shaft-Frame", 2e-9), ("Shaft-Frame_0100rpm", 0.5e-9),
                    ("Shaft-Frame_0300rpm", 0.3e-9)):
        write_spectrum(root / f"impedance/{name}.csv", FrequencyData(
            f, series_rlc(f, 0.1, 50e-9, c), "Z"))
    text = (root / "dataset.toml").read_text().replace(
        "[impedance]\n", '[impedance]\n"Shaft-Frame" = "impedance/Shaft-Frame.csv"\n')
    text += """
[[impedance_at_speed]]
topology = "Shaft-Frame"
speed_rpm = 300.0
file = "impedance/Shaft-Frame_0300rpm.csv"

[[impedance_at_speed]]
topology = "Shaft-Frame"
speed_rpm = 100
file = "impedance/Shaft-Frame_0100rpm.csv"

[machine]
rated_power_kw = 40.0
stator_bore_m = 0.2
air_gap_m = 0.0008
slots = 48

[bearing]
type = "deep_groove_ball"
balls = 10
ball_diameter_m = 0.0127
pitch_diameter_m = 0.07
lubricant_permittivity = 2.4

[priors]
"insulation.C_wr" = { median = 2e-10, gsd = 2.0 }
"lubricant.R_1" = { lower = 1e3, upper = 1e9 }
"""
    (root / "dataset.toml").write_text(text)
    # the 100-rpm record gains the two further channels
    rec = read_recording(root / "recordings/rpm0100.npz")
    rng = np.random.default_rng(1)
    data = np.vstack([rec.data, 0.9 * rec.data[3], rng.normal(0, 0.1, rec.n_samples)])
    arrays = dict(zip((*rec.channels, "u_B_DE", "i_CM"), data, strict=True))
    with open(root / "recordings/rpm0100.npz", "wb") as fh:
        np.savez(fh, fs=rec.fs, **arrays)
    return root


def test_further_measurements_are_carried_apart(ds_root: Path) -> None:
    ds = read_dataset(ds_root)
    # the paper's spectra only in .impedance: code iterating over it sees nothing new
    assert set(ds.impedance) <= set(TOPOLOGIES) and "Shaft-Frame" not in ds.impedance
    assert list(ds.further_impedance) == ["Shaft-Frame"]
    assert [(s.topology, s.speed_rpm) for s in ds.impedance_at_speed] == [
        ("Shaft-Frame", 100.0), ("Shaft-Frame", 300.0)]
    z = ds.impedance_at("Shaft-Frame", 300.0).values[:, 0, 0]
    f = ds.impedance_at("Shaft-Frame", 300.0).freq_hz
    np.testing.assert_allclose(z, series_rlc(f, 0.1, 50e-9, 0.3e-9), rtol=1e-9)
    assert ds.impedance_at("Shaft-Frame", 0.0) is ds.further_impedance["Shaft-Frame"]
    r0, r1 = ds.recordings
    assert r0.extra_channels == () and r0.bearing_de is None
    assert r1.extra_channels == ("u_B_DE", "i_CM")
    assert r1.bearing_de is not None
    np.testing.assert_allclose(r1.bearing_de, 0.9 * r1.bearing, rtol=1e-12)
    assert r1.channels[:4] == ("u_U", "u_V", "u_W", "u_B") and ds.has_further_measurements
    assert ds.machine is not None and ds.machine.air_gap_m == 0.0008 and ds.machine.slots == 48
    assert ds.bearing is not None and ds.bearing.lubricant_permittivity == 2.4
    assert ds.prior_overrides["lubricant.R_1"].upper == 1e9


def test_csv_recording_with_further_channels_round_trips(ds_root: Path) -> None:
    rec = read_recording(ds_root / "recordings/rpm0100.npz")
    write_recording(ds_root / "r.csv", rec)
    assert (ds_root / "r.csv").read_text().partition("\n")[0] == \
        "time_s,u_U,u_V,u_W,u_B,u_B_DE,i_CM"
    back = read_recording(ds_root / "r.csv")
    assert back.channels == rec.channels
    np.testing.assert_allclose(back.data, rec.data, rtol=1e-10, atol=1e-12)
    text = (ds_root / "r.csv").read_text().replace("u_B_DE", "u_B_XX", 1)
    (ds_root / "r.csv").write_text(text)
    with pytest.raises(InputError, match="unknown recording CSV header"):
        read_recording(ds_root / "r.csv")


def test_info_lists_them(ds_root: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_cli(capsys, ["info", str(ds_root)])
    assert code == 0, err
    for text in ("Shaft-Frame at standstill", "Shaft-Frame at 300 rpm", "u_B_DE", "i_CM",
                 "[machine]: rated_power_kw 40", "[priors] insulation.C_wr: median 2e-10"):
        assert text in out, text


@pytest.mark.parametrize(("old", "new", "words"), [
    ("slots = 48", "slots = 48\nbore_m = 0.2", ["[machine]", "unknown key 'bore_m'"]),
    ("balls = 10", "balls = 10.5", ["[bearing] balls", "integer"]),
    ("air_gap_m = 0.0008", "air_gap_m = -1e-3", ["[machine] air_gap_m", "out of range"]),
    ('type = "deep_groove_ball"', 'type = "roller"', ["[bearing] type", "unknown bearing"]),
    ("lubricant_permittivity = 2.4", "lubricant_permittivity = 0.5", ["out of range"]),
    ('{ median = 2e-10, gsd = 2.0 }', '{ median = 2e-10, gsd = 0.5 }', ["gsd"]),
    ('{ median = 2e-10, gsd = 2.0 }', '{ median = 2e-10 }', ["exactly median and gsd"]),
    ('"insulation.C_wr" =', '"insulation.C_xx" =', ["[priors] 'insulation.C_xx'",
                                                     "unknown parameter"]),
    ("speed_rpm = 300.0", "speed_rpm = 0.0", ["must be > 0"]),
    ("speed_rpm = 300.0", "speed_rpm = 100.0", ["two Shaft-Frame spectra at 100 rpm"]),
    ('topology = "Shaft-Frame"', 'topology = "Shaft-Rotor"', ["unknown topology"]),
    ("speed_rpm = 300.0", "speed_rpm = 300.0\nprobe = 1", ["unknown key 'probe'"]),
    ("[machine]", "[motor]", ["unknown key 'motor'"]),
])
def test_bad_tables_exit_2_naming_file_and_key(ds_root: Path, capsys: pytest.CaptureFixture[str],
                                               old: str, new: str, words: list[str]) -> None:
    toml = ds_root / "dataset.toml"
    text = toml.read_text()
    assert old in text
    toml.write_text(text.replace(old, new, 1))
    code, _, err = run_cli(capsys, ["info", str(ds_root)])
    assert code == 2
    assert "dataset.toml" in err and "Traceback" not in err and len(err.splitlines()) == 1
    for w in words:
        assert w in err, (w, err)
