"""Bad input (CONTRACT section 2): one clear message naming the file, exit 2, no output."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import make_dataset
from vfmodel.cli.main import main


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    code = main(list(argv))
    err = capsys.readouterr().err
    return code, err


def _check_rejected(code: int, err: str, must_name: str, problem: str) -> None:
    assert code == 2, err
    assert "Traceback" not in err
    lines = [ln for ln in err.strip().splitlines() if ln]
    assert len(lines) == 1, err
    assert must_name in lines[0], err
    assert problem in lines[0], err


CSV_CASES = {
    "missing": (None, "not found"),
    "unknown_columns": ("frequency_hz,re,im\n1,2,3\n", "unknown CSV column set"),
    "nan": ("frequency_hz,z_real_ohm,z_imag_ohm\n1,2,3\n2,nan,1\n", "NaN or infinite"),
    "inf": ("frequency_hz,z_real_ohm,z_imag_ohm\n1,2,3\n2,inf,1\n", "NaN or infinite"),
    "duplicate": ("frequency_hz,z_real_ohm,z_imag_ohm\n1,2,3\n1,2,3\n", "duplicate frequency"),
    "decreasing": ("frequency_hz,z_real_ohm,z_imag_ohm\n2,2,3\n1,2,3\n", "decreasing"),
    "empty": ("", "empty"),
    "garbage": (bytes(range(256)) * 8, "binary"),
    "text_in_number": ("frequency_hz,z_real_ohm,z_imag_ohm\n1,abc,3\n", "not a number"),
    "short_row": ("frequency_hz,z_real_ohm,z_imag_ohm\n1,2\n", "wrong number of fields"),
}


@pytest.mark.parametrize("case", sorted(CSV_CASES))
def test_bad_csv_spectrum(case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    content, problem = CSV_CASES[case]
    src = tmp_path / f"{case}.csv"
    if isinstance(content, bytes):
        src.write_bytes(content)
    elif content is not None:
        src.write_text(content)
    before = src.read_bytes() if src.exists() else None
    out = tmp_path / "out.s1p"
    code, err = _run(capsys, "convert", str(src), str(out))
    _check_rejected(code, err, str(src), problem)
    assert not out.exists()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".out")] == []
    assert (src.read_bytes() if src.exists() else None) == before  # input unchanged


TS_CASES: dict[str, tuple[bytes | str, str]] = {
    "garbage": (bytes(range(256)) * 8, "binary"),
    "no_option_line": ("! comment\n1 2 3\n", "no Touchstone option line"),
    "bad_data": ("# Hz S RI R 50\n1 2\n2 x y\n", "line 3: not a number"),
    "empty": ("   \n", "empty"),
    "decreasing": ("# Hz Z RI R 50\n2 1 0\n1 1 0\n", "decreasing frequency"),
}


@pytest.mark.parametrize("case", sorted(TS_CASES))
def test_bad_touchstone(case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    content, problem = TS_CASES[case]
    src = tmp_path / f"{case}.s1p"
    if isinstance(content, bytes):
        src.write_bytes(content)
    else:
        src.write_text(content)
    out = tmp_path / "out.csv"
    code, err = _run(capsys, "convert", str(src), str(out))
    _check_rejected(code, err, str(src), problem)
    assert not out.exists()


def _break(root: Path, case: str) -> tuple[Path, str]:
    """Damage one file of a valid dataset; return the file to be named and the problem."""
    rec = root / "recordings/rpm0100.npz"
    z = dict(np.load(rec))
    if case == "nonuniform_time":
        t = np.arange(z["u_U"].size) / 1e8
        t[100] += 3e-9
        del z["fs"]
        np.savez(rec, t=t, **z)
        return rec, "not uniformly spaced"
    if case == "unequal_channels":
        z["u_B"] = z["u_B"][:-5]
        np.savez(rec, **z)
        return rec, "unequal length"
    if case == "nan_sample":
        z["u_V"][17] = np.nan
        np.savez(rec, **z)
        return rec, "channel u_V"
    if case == "too_short":
        np.savez(rec, **{k: (v[:10] if v.ndim else v) for k, v in z.items()})
        return rec, "too short"
    if case == "missing_channel":
        del z["u_W"]
        np.savez(rec, **z)
        return rec, "missing array u_W"
    toml = root / "dataset.toml"
    text = toml.read_text()
    if case == "unknown_topology":
        toml.write_text(text.replace('"V-Frame" =', '"V-Rotor" ='))
        return toml, "unknown topology"
    if case == "malformed_toml":
        toml.write_text(text.replace("[impedance]", "[impedance"))
        return toml, "malformed TOML"
    if case == "missing_file":
        toml.write_text(text.replace("rpm0100.npz", "rpm9999.npz"))
        return root / "recordings/rpm9999.npz", "not found"
    if case == "garbage_npz":
        rec.write_bytes(os.urandom(2000))
        return rec, "not a readable NPZ"
    raise AssertionError(case)


DS_CASES = [
    "nonuniform_time", "unequal_channels", "nan_sample", "too_short", "missing_channel",
    "unknown_topology", "malformed_toml", "missing_file", "garbage_npz",
]


@pytest.mark.parametrize("case", DS_CASES)
def test_bad_dataset(case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    root = make_dataset(tmp_path / "ds", n_samples=512)
    named, problem = _break(root, case)
    code, err = _run(capsys, "info", str(root))
    _check_rejected(code, err, str(named), problem)


def test_unknown_output_suffix(tmp_path: Path, agilent: Path,
                               capsys: pytest.CaptureFixture[str]) -> None:
    code, err = _run(capsys, "convert", str(agilent), str(tmp_path / "x.xlsx"))
    _check_rejected(code, err, "x.xlsx", "unknown spectrum file type")


def test_usage_error_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["convert"]) == 2
    assert main(["nonsense-command"]) == 2


def test_touchstone_bad_option_line_found_by_fuzzing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Regression: an option line glued to data made scikit-rf produce NaN (hypothesis)."""
    src = tmp_path / "bad.s1p"
    src.write_bytes(b"! test\n2000 0.102 -0.022\n# Hz Z RI R,0.1 -0.064\n4000 0.106 0.05\n")
    code, err = _run(capsys, "convert", str(src), str(tmp_path / "out.csv"))
    assert code == 2 and str(src) in err and "Traceback" not in err
    assert not (tmp_path / "out.csv").exists()
