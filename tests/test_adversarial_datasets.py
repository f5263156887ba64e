"""Adversarial suite, datasets and recordings: broken ``dataset.toml``, paths that leave
the dataset, broken NPZ/CSV recordings, given to ``vfmodel info`` and ``vfmodel reproduce``
(refused before any computation; harness in tests/_adversarial.py)."""

from __future__ import annotations

import io
import os
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from benches.small_dataset import make_small_dataset
from tests._adversarial import assert_refused, copy_tree, run_cli, snapshot

SECRET = "SECRET-TOKEN-4711"
TOML = "dataset.toml"
REC = "recordings/rpm0000.npz"


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_small_dataset(tmp_path_factory.mktemp("adv") / "ds", seed=2, n_samples=1024)


def _toml(root: Path) -> str:
    return (root / TOML).read_text()


def _set_toml(root: Path, text: str) -> None:
    (root / TOML).write_text(text)


def _replace(root: Path, old: str, new: str) -> None:
    text = _toml(root)
    assert old in text, (old, text)
    _set_toml(root, text.replace(old, new, 1))


def _outside(root: Path) -> Path:
    p = root.parent / "outside.csv"
    p.write_text(f"{SECRET},z_real_ohm,z_imag_ohm\n1,2,3\n")
    return p


def _npz(root: Path, **arrays: object) -> None:
    with open(root / REC, "wb") as fh:
        np.savez(fh, **arrays)  # type: ignore[arg-type]


def _chans(n: int = 1024) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    return {c: rng.normal(size=n) for c in ("u_U", "u_V", "u_W", "u_B")}


IMP = '"U-Frame" = "impedance/U-Frame.csv"'
SPEED0 = "speed_rpm = 0.0"
FILE0 = f'file = "{REC}"'


def _m(fn: Callable[[Path], object], *names: str) -> Callable[[Path], tuple[str, ...]]:
    def go(root: Path) -> tuple[str, ...]:
        fn(root)
        return tuple(n.replace("@", str(root)) for n in names)
    return go


def _symlink_file(root: Path) -> None:
    out = _outside(root)
    (root / "impedance" / "link.csv").symlink_to(out)
    _replace(root, IMP, '"U-Frame" = "impedance/link.csv"')


def _symlink_dir(root: Path) -> None:
    _outside(root)
    (root / "up").symlink_to(root.parent)
    _replace(root, IMP, '"U-Frame" = "up/outside.csv"')


def _symlink_loop(root: Path) -> None:
    (root / "loop.csv").symlink_to(root / "loop.csv")
    _replace(root, IMP, '"U-Frame" = "loop.csv"')


def _forged_npz(root: Path) -> None:
    """A small NPZ whose u_B header declares 2.5e8 samples (2 GB) the member does not hold."""
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"descr": "<f8", "fortran_order": False, "shape": (250_000_000,)})
    chans = _chans()
    with zipfile.ZipFile(root / REC, "w", zipfile.ZIP_DEFLATED) as zf:
        for c in ("u_U", "u_V", "u_W"):
            b = io.BytesIO()
            np.save(b, chans[c])
            zf.writestr(f"{c}.npy", b.getvalue())
        zf.writestr("u_B.npy", buf.getvalue() + b"\0" * 2_000_000)
        b = io.BytesIO()
        np.save(b, np.float64(1e8))
        zf.writestr("fs.npy", b.getvalue())


def _non_npy_member(root: Path) -> None:
    with zipfile.ZipFile(root / REC, "w") as zf:
        zf.writestr("readme.txt", SECRET)


def _csv_rec(root: Path, text: str | bytes) -> None:
    p = root / "recordings" / "r.csv"
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text)
    _replace(root, FILE0, 'file = "recordings/r.csv"')


_HDR = "time_s,u_U,u_V,u_W,u_B\n"


def _rows(n: int = 100, dt: float = 1e-8) -> str:
    return "".join(f"{k * dt:.10g},1,2,3,{k % 7}\n" for k in range(n))


DATASET_CASES: dict[str, Callable[[Path], tuple[str, ...]]] = {
    "toml_malformed": _m(lambda r: _set_toml(r, "name = \n[impedance\n"), "@/dataset.toml"),
    "toml_missing": _m(lambda r: (r / TOML).unlink(), "@/dataset.toml"),
    "toml_empty": _m(lambda r: _set_toml(r, ""), "@/dataset.toml"),
    "toml_binary": _m(lambda r: (r / TOML).write_bytes(b"\x00\x01name"), "@/dataset.toml"),
    "toml_is_dir": _m(lambda r: ((r / TOML).unlink(), (r / TOML).mkdir()),  # type: ignore[func-returns-value]
                      "@/dataset.toml"),
    "unknown_top_key": _m(lambda r: _set_toml(r, "speed = 3\n" + _toml(r)), "speed"),
    "unknown_recording_key": _m(lambda r: _replace(r, SPEED0, SPEED0 + "\nsped_rpm = 5"),
                                "sped_rpm"),
    "recording_key_typo_only": _m(lambda r: _replace(r, SPEED0, "speed_rmp = 0.0"),
                                  "speed_r"),
    "speed_nan": _m(lambda r: _replace(r, SPEED0, "speed_rpm = nan"), "speed_rpm"),
    "speed_inf": _m(lambda r: _replace(r, SPEED0, "speed_rpm = inf"), "speed_rpm"),
    "speed_neg_inf": _m(lambda r: _replace(r, SPEED0, "speed_rpm = -inf"), "speed_rpm"),
    "speed_string": _m(lambda r: _replace(r, SPEED0, 'speed_rpm = "100"'), "speed_rpm"),
    "speed_bool": _m(lambda r: _replace(r, SPEED0, "speed_rpm = true"), "speed_rpm"),
    "speed_array": _m(lambda r: _replace(r, SPEED0, "speed_rpm = [1, 2]"), "speed_rpm"),
    "temperature_nan": _m(lambda r: _replace(r, "temperature_c = 80.0", "temperature_c = nan"),
                          "temperature_c"),
    "temperature_string": _m(lambda r: _replace(r, "temperature_c = 80.0",
                                                'temperature_c = "hot"'), "temperature_c"),
    "name_not_string": _m(lambda r: _replace(r, 'name = "small-example"', "name = 3"), "name"),
    "impedance_not_table": _m(lambda r: _set_toml(r, 'impedance = "x"\n'), "@/dataset.toml"),
    "unknown_topology": _m(lambda r: _replace(r, '"U-Frame" =', '"U-Ground" ='), "U-Ground"),
    "impedance_path_int": _m(lambda r: _replace(r, IMP, '"U-Frame" = 3'), "U-Frame"),
    "impedance_missing_file": _m(lambda r: (r / "impedance" / "U-Frame.csv").unlink(),
                                 "@/impedance/U-Frame.csv"),
    "impedance_is_dir": _m(lambda r: _replace(r, IMP, '"U-Frame" = "impedance"'),
                           "@/impedance"),
    "impedance_empty_path": _m(lambda r: _replace(r, IMP, '"U-Frame" = ""'), "U-Frame"),
    "impedance_dotdot": _m(lambda r: (_outside(r), _replace(r, IMP,  # type: ignore[func-returns-value]
                           '"U-Frame" = "../outside.csv"')), "../outside.csv"),
    "impedance_dotdot_inner": _m(lambda r: (_outside(r), _replace(  # type: ignore[func-returns-value]
        r, IMP, '"U-Frame" = "impedance/../../outside.csv"')), "outside.csv"),
    "impedance_absolute": _m(lambda r: _replace(r, IMP, f'"U-Frame" = "{_outside(r)}"'),
                             "outside.csv"),
    "impedance_etc_passwd": _m(lambda r: _replace(r, IMP, '"U-Frame" = "/etc/passwd"'),
                               "/etc/passwd"),
    "impedance_symlink_file": _m(_symlink_file, "link.csv"),
    "impedance_symlink_dir": _m(_symlink_dir, "up/outside.csv"),
    "impedance_symlink_loop": _m(_symlink_loop, "loop.csv"),
    "impedance_nul_in_path": _m(lambda r: _replace(r, IMP, '"U-Frame" = "a\\u0000b.csv"'),
                                "U-Frame"),
    "impedance_2port": _m(lambda r: ((r / "impedance" / "two.s2p").write_text(
        "# Hz S RI\n1 0 0 0 0 0 0 0 0\n2 0 0 0 0 0 0 0 0\n3 0 0 0 0 0 0 0 0\n"),
        _replace(r, IMP, '"U-Frame" = "impedance/two.s2p"')),  # type: ignore[func-returns-value]
        "@/impedance/two.s2p"),
    "impedance_bad_csv": _m(lambda r: (r / "impedance" / "U-Frame.csv").write_text(
        "frequency_hz,z_real_ohm,z_imag_ohm\n1,2,nan\n"), "@/impedance/U-Frame.csv"),
    "recording_not_array": _m(lambda r: _set_toml(r, 'recording = "x"\n'), "@/dataset.toml"),
    "recording_not_tables": _m(lambda r: _set_toml(r, "recording = [1, 2]\n"),
                               "@/dataset.toml"),
    "recording_missing_file_key": _m(lambda r: _replace(r, FILE0, ""), "file"),
    "recording_file_int": _m(lambda r: _replace(r, FILE0, "file = 3"), "file"),
    "recording_dotdot": _m(lambda r: _replace(r, FILE0, 'file = "../rec.npz"'), "../rec.npz"),
    "recording_absolute": _m(lambda r: _replace(r, FILE0, 'file = "/tmp/x.npz"'), "/tmp/x.npz"),
    "recording_missing": _m(lambda r: (r / REC).unlink(), "@/" + REC),
    "recording_suffix": _m(lambda r: _replace(r, FILE0, 'file = "recordings/r.mat"'),
                           "recordings/r.mat"),
    "duplicate_speed": _m(lambda r: _replace(r, "speed_rpm = 100.0", SPEED0),
                          "@/dataset.toml"),
    "dataset_dir_missing": _m(lambda r: None, "@/nonexistent"),
}


@pytest.mark.parametrize("case", sorted(DATASET_CASES))
@pytest.mark.parametrize("command", ["info", "reproduce"])
def test_bad_dataset(case: str, command: str, base: Path, tmp_path: Path,
                     capsys: pytest.CaptureFixture[str]) -> None:
    root = copy_tree(base, tmp_path / "ds")
    names = DATASET_CASES[case](root)
    target = root / "nonexistent" if case == "dataset_dir_missing" else root
    before = snapshot(tmp_path)
    argv = [command, str(target)]
    if command == "reproduce":
        argv += ["--out", str(tmp_path / "out")]
    res = run_cli(capsys, argv)
    assert_refused(res, names, before, tmp_path, secret=SECRET)


RECORDING_CASES: dict[str, Callable[[Path], tuple[str, ...]]] = {
    "missing_u_b": _m(lambda r: _npz(r, fs=1e8, **{k: v for k, v in _chans().items()
                                                   if k != "u_B"}), "u_B"),
    "unequal_lengths": _m(lambda r: _npz(r, fs=1e8, **{**_chans(), "u_B": np.zeros(1000)}),
                          "u_B"),
    "channel_2d": _m(lambda r: _npz(r, fs=1e8, **{**_chans(), "u_V": np.zeros((2, 512))}),
                     "u_V"),
    "channel_complex": _m(lambda r: _npz(r, fs=1e8, **{**_chans(),
                                                       "u_W": np.zeros(1024, complex)}),
                          "u_W"),
    "channel_strings": _m(lambda r: _npz(r, fs=1e8, **{**_chans(),
                                                       "u_U": np.array(["a"] * 1024)}),
                          "u_U"),
    "channel_objects": _m(lambda r: _npz(r, fs=1e8, **{**_chans(),
                                                       "u_U": np.array([1, "a"], object)}),
                          "@/" + REC),
    "t_complex": _m(lambda r: _npz(r, t=np.arange(1024) * (1e-8 + 0j), **_chans()), "t"),
    "fs_complex": _m(lambda r: _npz(r, fs=np.complex128(1e8 + 1j), **_chans()), "fs"),
    "fs_bool": _m(lambda r: _npz(r, fs=np.bool_(True), **_chans()), "fs"),
    "fs_zero": _m(lambda r: _npz(r, fs=0.0, **_chans()), "fs"),
    "fs_negative": _m(lambda r: _npz(r, fs=-1e8, **_chans()), "fs"),
    "fs_nan": _m(lambda r: _npz(r, fs=np.nan, **_chans()), "fs"),
    "fs_inf": _m(lambda r: _npz(r, fs=np.inf, **_chans()), "fs"),
    "fs_vector": _m(lambda r: _npz(r, fs=np.array([1e8, 2e8]), **_chans()), "fs"),
    "fs_string": _m(lambda r: _npz(r, fs=np.array("1e8"), **_chans()), "fs"),
    "t_fs_disagree": _m(lambda r: _npz(r, fs=1e8, t=np.arange(1024) * 2e-8, **_chans()),
                        "t and fs"),
    "t_nonuniform": _m(lambda r: _npz(r, t=np.cumsum(np.r_[0, np.full(1023, 1e-8)]
                                                     * np.r_[1, 1 + (np.arange(1023) == 9)]),
                                      **_chans()), "@/" + REC),
    "t_decreasing": _m(lambda r: _npz(r, t=-np.arange(1024) * 1e-8, **_chans()), "@/" + REC),
    "t_nan": _m(lambda r: _npz(r, t=np.r_[np.nan, np.arange(1023) * 1e-8], **_chans()),
                "@/" + REC),
    "t_length": _m(lambda r: _npz(r, t=np.arange(1000) * 1e-8, **_chans()), "t"),
    "too_short": _m(lambda r: _npz(r, fs=1e8, **_chans(10)), "@/" + REC),
    "no_time_axis": _m(lambda r: _npz(r, **_chans()), "@/" + REC),
    "unknown_array": _m(lambda r: _npz(r, fs=1e8, u_X=np.zeros(3), **_chans()), "u_X"),
    "nan_sample": _m(lambda r: _npz(r, fs=1e8, **{**_chans(), "u_B": np.r_[np.nan,
                                                                          np.zeros(1023)]}),
                     "@/" + REC),
    "forged_header_2p5e8": _m(_forged_npz, "u_B"),
    "not_a_zip": _m(lambda r: (r / REC).write_text(f"{SECRET}\n"), "@/" + REC),
    "truncated_zip": _m(lambda r: (r / REC).write_bytes((r / REC).read_bytes()[:300]),
                        "@/" + REC),
    "empty_npz_file": _m(lambda r: (r / REC).write_bytes(b""), "@/" + REC),
    "non_npy_member": _m(_non_npy_member, "@/" + REC),
    "csv_bad_header": _m(lambda r: _csv_rec(r, "t,u_U,u_V,u_W,u_B\n" + _rows()), "r.csv"),
    "csv_missing_column": _m(lambda r: _csv_rec(r, "time_s,u_U,u_V,u_W\n1,2,3,4\n"), "r.csv"),
    "csv_nan": _m(lambda r: _csv_rec(r, _HDR + _rows().replace(",1,2,", ",nan,2,", 1)),
                  "r.csv"),
    "csv_text_value": _m(lambda r: _csv_rec(r, _HDR + "0,a,b,c,d\n" + _rows()), "r.csv"),
    "csv_nonuniform": _m(lambda r: _csv_rec(r, _HDR + _rows(50) + "1e-5,1,2,3,4\n"),
                         "r.csv"),
    "csv_header_only": _m(lambda r: _csv_rec(r, _HDR), "r.csv"),
    "csv_empty": _m(lambda r: _csv_rec(r, ""), "r.csv"),
    "csv_binary": _m(lambda r: _csv_rec(r, b"\x00" * 100), "r.csv"),
    "csv_short_rows": _m(lambda r: _csv_rec(r, _HDR + "0,1,2\n"), "r.csv"),
}


@pytest.mark.parametrize("case", sorted(RECORDING_CASES))
def test_bad_recording(case: str, base: Path, tmp_path: Path,
                       capsys: pytest.CaptureFixture[str]) -> None:
    root = copy_tree(base, tmp_path / "ds")
    names = RECORDING_CASES[case](root)
    before = snapshot(tmp_path)
    res = run_cli(capsys, ["info", str(root)])
    assert_refused(res, names, before, tmp_path, secret=SECRET)


def test_recording_longer_than_the_limit_refused_from_its_header(
        base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    import vfmodel.core.io_recording as rec

    monkeypatch.setattr(rec, "MAX_SAMPLES", 1000)   # the base records hold 1024 samples
    root = copy_tree(base, tmp_path / "ds")
    before = snapshot(tmp_path)
    res = run_cli(capsys, ["info", str(root)])
    assert_refused(res, "array too large", before, tmp_path)


def test_excel_bom_recording_csv_is_accepted(base: Path, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    root = copy_tree(base, tmp_path / "ds")
    _csv_rec(root, ("\ufeff" + _HDR + _rows(256)).encode())
    res = run_cli(capsys, ["info", str(root), "--json"])
    assert res.code == 0, res.err


def test_allow_outside_is_explicit(base: Path, tmp_path: Path) -> None:
    from vfmodel.core.io_dataset import read_dataset
    from vfmodel.errors import InputError

    root = copy_tree(base, tmp_path / "ds")
    (tmp_path / "shared").mkdir()
    os.replace(root / "impedance" / "U-Frame.csv", tmp_path / "shared" / "U.csv")
    _replace(root, IMP, '"U-Frame" = "../shared/U.csv"')
    with pytest.raises(InputError, match="outside the dataset"):
        read_dataset(root, load_recordings=False)
    ds = read_dataset(root, load_recordings=False, allow_outside=True)
    assert "U-Frame" in ds.impedance
