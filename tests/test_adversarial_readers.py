"""Adversarial suite, readers: malformed spectrum files given to ``vfmodel convert`` and
``model.json`` files given to the API (issue 16; harness in tests/_adversarial.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tests._adversarial import assert_refused, run_cli, snapshot, z_csv
from vfmodel.core.io_spectrum import read_spectrum
from vfmodel.errors import InputError

H = "frequency_hz,z_real_ohm,z_imag_ohm\n"
G2 = "frequency_hz," + ",".join(f"y{i}_{j}_{p}" for i in (1, 2) for j in (1, 2)
                                for p in ("real", "imag")) + "\n"

CSV_CASES: dict[str, str | bytes] = {
    "empty": "",
    "whitespace": "  \n\n ",
    "header_only": H,
    "unknown_header": "f,zr,zi\n1,2,3\n",
    "header_typo": "frequency_hz,z_real_ohm,z_imag_ohms\n1,2,3\n",
    "header_case": "Frequency_Hz,Z_Real_Ohm,Z_Imag_Ohm\n1,2,3\n",
    "two_columns": "frequency_hz,z_real_ohm\n1,2\n",
    "nan_value": H + "1,nan,3\n2,2,3\n",
    "inf_value": H + "1,inf,3\n2,2,3\n",
    "neg_inf_freq": H + "-inf,1,3\n2,2,3\n",
    "nan_freq": H + "nan,1,3\n2,2,3\n",
    "text_value": H + "1,abc,3\n2,2,3\n",
    "empty_cell": H + "1,,3\n2,2,3\n",
    "short_row": H + "1,2\n2,2,3\n",
    "long_row": H + "1,2,3,4\n2,2,3\n",
    "decreasing": H + "2,1,1\n1,1,1\n",
    "duplicate_freq": H + "1,1,1\n1,1,1\n",
    "negative_freq": H + "-1,1,1\n2,1,1\n",
    "semicolon_sep": "frequency_hz;z_real_ohm;z_imag_ohm\n1;2;3\n",
    "decimal_comma": H + '1,"2,5",3\n',
    "negative_magnitude": "frequency_hz,z_mag_ohm,z_phase_deg\n1,-2,3\n2,2,3\n",
    "binary_nul": b"frequency_hz,z_real_ohm\x00,z_imag_ohm\n1,2,3\n",
    "binary_random": bytes(np.random.default_rng(3).integers(0, 256, 4000, dtype=np.uint8)),
    "latin1_garbage": "frequency_hz,z_real_ohm,z_imag_ohm\n1,2,\xe9\n".encode("latin-1"),
    "invalid_utf8": b"frequency_hz,z_real_ohm,z_imag_ohm\n1,2,3\n\xff\xfe\xfd\x80" * 3,
    "huge_index_header": "frequency_hz,z1000000_1000000_real,z1000000_1000000_imag\n1,2,3\n",
    "huge_index_many_rows": "frequency_hz,y300_300_real,y300_300_imag\n" + "1,2,3\n" * 2000,
    "zero_index": "frequency_hz,z0_0_real,z0_0_imag\n1,2,3\n",
    "mixed_kinds": "frequency_hz,z1_1_real,y1_1_imag\n1,2,3\n",
    "missing_entries": "frequency_hz,z1_1_real,z1_1_imag,z2_2_real,z2_2_imag\n1,2,3,4,5\n",
    "duplicate_column": "frequency_hz,z1_1_real,z1_1_real\n1,2,3\n",
    "generic_even": "frequency_hz,z1_1_real\n1,2\n",
    "bad_z0_comment": "# z0_ohm=abc\nfrequency_hz,s1_1_real,s1_1_imag\n1,0.1,0\n",
    "zero_z0": "# z0_ohm=0\nfrequency_hz,s1_1_real,s1_1_imag\n1,0.1,0\n2,0.1,0\n",
    "negative_z0": "# z0_ohm=-50\nfrequency_hz,s1_1_real,s1_1_imag\n1,0.1,0\n2,0.1,0\n",
    "overflow_number": H + "1,1e999,3\n2,2,3\n",
    "y_nan_2port": G2 + "1," + ",".join(["nan"] * 8) + "\n",
    "y_short_2port": G2 + "1,1,2,3\n",
    "only_comments": "# z0_ohm=50\n# nothing\n",
    "html_page": "<!DOCTYPE html><html><body>404 not found</body></html>\n",
    "json_doc": '{"frequency_hz": [1, 2], "z": [1, 2]}\n',
    "hex_numbers": H + "0x10,1,1\n0x20,1,1\n",
    "bom_then_garbage": "\ufeffgarbage,header\n1,2\n".encode(),
    "one_point_only_header_typo": "frequency,z_real_ohm,z_imag_ohm\n1,2,3\n",
}

_P = "1 0.1 0.2 0.3 0.4 0.5 0.6 0.7 0.8\n"
TS_CASES: dict[str, tuple[str, str | bytes]] = {
    "ts_empty": (".s1p", ""),
    "ts_no_option": (".s1p", "! c\n1 2 3\n"),
    "ts_option_after_data": (".s1p", "1 2 3\n# Hz S RI\n"),
    "ts_unknown_field": (".s1p", "# Hz S RI Q 50\n1 0 0\n"),
    "ts_r_missing_value": (".s1p", "# Hz S RI R\n1 0 0\n"),
    "ts_r_negative": (".s1p", "# Hz S RI R -50\n1 0 0\n"),
    "ts_r_zero": (".s1p", "# Hz S RI R 0\n1 0 0\n"),
    "ts_r_text": (".s1p", "# Hz S RI R fifty\n1 0 0\n"),
    "ts_r_inf": (".s1p", "# Hz S RI R inf\n1 0 0\n"),
    "ts_two_units": (".s1p", "# Hz MHz S RI\n1 0 0\n"),
    "ts_two_formats": (".s1p", "# Hz S RI MA\n1 0 0\n"),
    "ts_g_params": (".s2p", "# Hz G RI\n" + _P),
    "ts_h_params": (".s2p", "# Hz H RI\n" + _P),
    "ts_nan": (".s1p", "# Hz S RI\n1 nan 0\n2 0 0\n"),
    "ts_inf": (".s1p", "# Hz S RI\n1 inf 0\n2 0 0\n"),
    "ts_text": (".s1p", "# Hz S RI\n1 zero 0\n"),
    "ts_incomplete_row": (".s1p", "# Hz S RI\n1 0 0\n2 0\n"),
    "ts_extra_numbers": (".s1p", "# Hz S RI\n1 0 0 0\n"),
    "ts_decreasing_1port": (".s1p", "# Hz S RI\n2 0 0\n1 0 0\n"),
    "ts_repeated_1port": (".s1p", "# Hz S RI\n1 0 0\n1 0 0\n"),
    "ts_2port_swapped_rows": (".s2p", "# GHz S RI\n" + "".join(
        f"{f} 0.1 0.2 0.3 0.4 0.5 0.6 0.7 0.8\n" for f in (1, 2, 3, 5, 4, 6, 7, 8, 9, 10))),
    "ts_2port_repeated": (".s2p", "# GHz S RI\n" + _P + _P),
    "ts_2port_bad_noise": (".s2p", "# GHz S RI\n" + _P + "2" + _P[1:] + "1 0.5 0.3 40\n"),
    "ts_2port_row_split_wrong": (".s2p", "# GHz S RI\n1 0.1 0.2 0.3\n0.4 0.5 0.6 0.7 0.8 9\n"),
    "ts_port_mismatch": (".s2p", "# Hz S RI\n1 0 0\n2 0 0\n"),
    "ts_3port_short": (".s3p", "# Hz S RI\n1 " + " ".join(["0"] * 17) + "\n"),
    "ts_s0p": (".s0p", "# Hz S RI\n1\n"),
    "ts_huge_port_count": (".s100000p", "# Hz S RI\n1 0 0\n"),
    "ts_binary_nul": (".s1p", b"# Hz S RI\n\x00\x00\x01\x02" * 100),
    "ts_binary_random": (".s2p", bytes(np.random.default_rng(5).integers(
        0, 256, 3000, dtype=np.uint8))),
    "ts_keyword_in_v1": (".s1p", "# Hz S RI\n[Number of Ports] 1\n1 0 0\n"),
    "ts_ts_without_version": (".ts", "# Hz S RI\n1 0 0\n"),
    "ts_v2_broken": (".ts", "[Version] 2.0\n# Hz S RI R 50\n[Number of Ports] x\n"),
    "ts_v2_decreasing": (".ts", "[Version] 2.0\n# Hz S RI R 50\n[Number of Ports] 1\n"
                         "[Network Data]\n2 0 0\n1 0 0\n[End]\n"),
    "ts_overflow_db": (".s1p", "# Hz S DB\n1 1e308 0\n2 0 0\n"),
    "ts_negative_freq": (".s1p", "# Hz S RI\n-1 0 0\n2 0 0\n"),
    "ts_only_comments": (".s1p", "! one\n! two\n# Hz S RI\n! three\n"),
    "ts_html": (".s1p", "<html><body>Not found</body></html>\n"),
    "ts_unknown_suffix": (".sxp", "# Hz S RI\n1 0 0\n"),
}


def _write(p: Path, content: str | bytes) -> None:
    if isinstance(content, bytes):
        p.write_bytes(content)
    else:
        p.write_text(content, encoding="utf-8")


@pytest.mark.parametrize("case", sorted(CSV_CASES))
def test_bad_spectrum_csv(case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    src = tmp_path / f"{case}.csv"
    _write(src, CSV_CASES[case])
    before = snapshot(tmp_path)
    res = run_cli(capsys, ["convert", str(src), str(tmp_path / "out" / "x.s1p")])
    assert_refused(res, str(src), before, tmp_path)


@pytest.mark.parametrize("case", sorted(TS_CASES))
def test_bad_touchstone(case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    suffix, content = TS_CASES[case]
    src = tmp_path / f"{case}{suffix}"
    _write(src, content)
    before = snapshot(tmp_path)
    res = run_cli(capsys, ["convert", str(src), str(tmp_path / "x.csv")])
    assert_refused(res, str(src), before, tmp_path)


# ---------------------------------------------------------------- accepted as documented
GOOD: dict[str, tuple[str, str | bytes, int]] = {
    "excel_bom_csv": (".csv", ("\ufeff" + z_csv(5)).encode(), 5),
    "crlf_csv": (".csv", z_csv(5).replace("\n", "\r\n"), 5),
    "blank_lines_csv": (".csv", z_csv(5).replace("\n", "\n\n"), 5),
    "any_order_options": (".s1p", "# MHz MA S R 50\n1 0.5 10\n2 0.5 20\n", 2),
    "lowercase_options": (".s1p", "# mhz s ri r 75\n1 0.5 0\n2 0.5 0\n", 2),
    "comments_everywhere": (".s1p", "! a\n\n# Hz Z RI R 50 ! opt\n! b\n1 1 0 ! c\n\n2 1 0\n", 2),
    "default_options": (".s1p", "#\n1 0.5 10\n2 0.5 20\n", 2),
    "bom_touchstone": (".s1p", "\ufeff# Hz S RI\n1 0.5 0\n2 0.5 0\n".encode(), 2),
    "noise_block": (".s2p", "# GHz S RI\n" + _P + "2" + _P[1:] + "1 0.5 0.3 40 0.2\n", 2),
    "wrapped_3port": (".s3p", "# Hz S RI\n1 " + " ".join(["0.1"] * 8) + "\n"
                      + " ".join(["0.1"] * 8) + "\n" + " ".join(["0.1"] * 2) + "\n", 1),
}


@pytest.mark.parametrize("case", sorted(GOOD))
def test_accepted_inputs(case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    suffix, content, n = GOOD[case]
    src = tmp_path / f"{case}{suffix}"
    _write(src, content)
    before = src.read_bytes()
    res = run_cli(capsys, ["convert", str(src), str(tmp_path / "out.csv")])
    assert res.code == 0, res.err
    assert src.read_bytes() == before
    assert read_spectrum(tmp_path / "out.csv").n_freq == n


# ---------------------------------------------------------------- model.json (API)
_GOOD_MODEL = {"kind": "Z", "z0": None, "n_out": 1, "n_in": 1, "poles": [[-1e3, 0.0]],
               "residues": [[[[1e3, 0.0]]]], "d": [[1.0]], "e": [[0.0]],
               "freq_range_hz": [1.0, 1e6], "rms_error": 0.0, "rel_rms_error": 0.0,
               "passive": None}
MODEL_CASES: dict[str, str | bytes] = {
    "mj_empty": "",
    "mj_not_json": "kind: Z\n",
    "mj_list": "[1, 2, 3]\n",
    "mj_nan_token": json.dumps(_GOOD_MODEL).replace('"rms_error": 0.0', '"rms_error": NaN'),
    "mj_binary": b"\x00\x01\x02",
    "mj_missing_poles": json.dumps({k: v for k, v in _GOOD_MODEL.items() if k != "poles"}),
    "mj_bad_kind": json.dumps({**_GOOD_MODEL, "kind": "Q"}),
    "mj_residue_shape": json.dumps({**_GOOD_MODEL, "residues": [[[1.0]]]}),
    "mj_pole_text": json.dumps({**_GOOD_MODEL, "poles": [["a", 0]]}),
    "mj_unstable_inf": json.dumps({**_GOOD_MODEL, "poles": [[1e309, 0]]}).replace(
        "Infinity", "1e999"),
    "mj_d_wrong_shape": json.dumps({**_GOOD_MODEL, "d": [[1.0, 2.0]]}),
    "mj_truncated": json.dumps(_GOOD_MODEL)[:40],
}


# every malformed model.json is refused with an InputError naming the file
@pytest.mark.parametrize("case", sorted(MODEL_CASES))
def test_bad_model_json(case: str, tmp_path: Path) -> None:
    from vfmodel.fitting.model_json import read_model_json

    p = tmp_path / "model.json"
    _write(p, MODEL_CASES[case])
    with pytest.raises(InputError) as info:
        read_model_json(p)
    assert str(p) in str(info.value)


def test_good_model_json_reads(tmp_path: Path) -> None:
    from vfmodel.fitting.model_json import read_model_json

    p = tmp_path / "model.json"
    p.write_text(json.dumps(_GOOD_MODEL))
    m = read_model_json(p)
    assert abs(m(np.array([0.0]))[0, 0, 0] - 2.0) < 1e-12   # 1e3/(0+1e3) + 1
