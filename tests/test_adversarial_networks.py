"""Adversarial suite, networks: user networks for ``vfmodel diagnose --model``, model
netlists and ``--inverter`` options for ``vfmodel predict``, and networks too large to fit
(issue 16; harness in tests/_adversarial.py)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from tests._adversarial import (
    GREYBOX_NETLIST,
    USER_MODEL,
    assert_refused,
    run_cli,
    snapshot,
    z_csv,
)

SECRET = "SECRET-TOKEN-4711"


def _user_case(tmp_path: Path, text: str | bytes) -> tuple[Path, Path]:
    ds = tmp_path / "ds"
    (ds / "impedance").mkdir(parents=True)
    (ds / "impedance" / "Zin.csv").write_text(z_csv())
    model = tmp_path / "model.net"
    if isinstance(text, bytes):
        model.write_bytes(text)
    else:
        model.write_text(text)
    return ds, model


def _edit(old: str, new: str) -> str:
    assert old in USER_MODEL
    return USER_MODEL.replace(old, new, 1)


def _ladder(n_nodes: int) -> str:
    lines = ["* long ladder"]
    for k in range(n_nodes):
        lines.append(f"R{k} n{k} n{k + 1} 1")
        lines.append(f"C{k} n{k + 1} 0 1n")
    return "\n".join([*lines, ".port Zin n0 0", ".end"]) + "\n"


def _many_params(n: int) -> str:
    lines = ["* many free parameters"]
    for k in range(n):
        lines.append(f"R{k} in 0 {1000 + k} [1 1e6]")
    return "\n".join([*lines, ".port Zin in 0", ".end"]) + "\n"


R2 = "R2 n1 n2 47"
C1 = "C1 n1 0 10n [1n 100n]"
PORT = ".port Zin in 0"
USER_CASES: dict[str, tuple[str | bytes, str]] = {
    "zero_value": (_edit(R2, "R2 n1 n2 0"), "line 5"),
    "negative_value": (_edit(R2, "R2 n1 n2 -47"), "line 5"),
    "inf_value": (_edit(R2, "R2 n1 n2 1e999"), "line 5"),
    "nan_value": (_edit(R2, "R2 n1 n2 nan"), "line 5"),
    "text_value": (_edit(R2, "R2 n1 n2 abc"), "line 5"),
    "zero_lower_bound": (_edit(C1, "C1 n1 0 10n [0 100n]"), "line 4"),
    "inverted_bounds": (_edit(C1, "C1 n1 0 10n [100n 1n]"), "line 4"),
    "nominal_outside_bounds": (_edit(C1, "C1 n1 0 1 [1n 100n]"), "line 4"),
    "inf_upper_bound": (_edit(C1, "C1 n1 0 10n [1n inf]"), "line 4"),
    "param_field_count": (_edit(".param rs 50 5 500", ".param rs 50 5"), "line 2"),
    "param_negative": (_edit(".param rs 50 5 500", ".param rs -50 5 500"), "line 2"),
    "param_duplicate": (_edit(".param rs 50 5 500", ".param rs 50 5 500\n.param rs 1 1 2"),
                        "line 3"),
    "unknown_param_ref": (_edit("{rs}", "{q}"), "q"),
    "floating_subnetwork": (_edit(R2, R2 + "\nR9 x y 10\nC9 y x 1n"), "line 6"),
    "port_missing_node": (_edit(PORT, ".port Zin nowhere 0"), "line 7"),
    "port_same_node": (_edit(PORT, ".port Zin 0 0"), "line 7"),
    "port_same_node_nonground": (_edit(PORT, ".port Zin in in"), "line 7"),
    "port_duplicate": (_edit(PORT, PORT + "\n.port Zin n1 0"), "line 8"),
    "port_fields": (_edit(PORT, ".port Zin"), "line 7"),
    "duplicate_element": (_edit(R2, R2 + "\nR2 n2 0 1"), "line 6"),
    "element_same_node": (_edit(R2, "R2 n1 n1 47"), "line 5"),
    "unknown_card": (_edit(PORT, PORT + "\n.foo bar"), "line 8"),
    "unknown_element": (_edit(R2, "Q2 n1 n2 47"), "line 5"),
    "element_fields": (_edit(R2, "R2 n1 n2"), "line 5"),
    "unknown_effect": (_edit(".effect insulation_dielectric_loss C1 C2",
                             ".effect frobnication C1"), "line 8"),
    "effect_wrong_place": (_edit(".effect insulation_dielectric_loss C1 C2",
                                 ".effect insulation_dielectric_loss R2"), "R2"),
    "effect_no_place": (_edit(".effect insulation_dielectric_loss C1 C2", ".effect x"),
                        "line 8"),
    "no_port": (_edit(PORT, ""), "model.net"),
    "empty_file": ("", "model.net"),
    "binary_file": (b"\x00\x01\x02R1 a 0 1", "model.net"),
    "huge_ladder_2001_nodes": (_ladder(2001), "too large"),
    "free_params_600": (_many_params(600), "too large"),
    "port_file_dotdot": (_edit(PORT, ".port Zin in 0 ../secret.csv"), ".port Zin"),
    "port_file_absolute": (_edit(PORT, ".port Zin in 0 /etc/passwd"), ".port Zin"),
    "port_file_missing": (_edit(PORT, ".port Zin in 0 impedance/none.csv"), "none.csv"),
}


@pytest.mark.parametrize("case", sorted(USER_CASES))
def test_bad_user_network(case: str, tmp_path: Path,
                          capsys: pytest.CaptureFixture[str]) -> None:
    text, where = USER_CASES[case]
    ds, model = _user_case(tmp_path, text)
    (tmp_path / "secret.csv").write_text(f"{SECRET}\n")
    before = snapshot(tmp_path)
    t0 = time.perf_counter()
    res = run_cli(capsys, ["diagnose", str(ds), "--model", str(model), "--out",
                           str(tmp_path / "out")])
    assert time.perf_counter() - t0 < 10.0       # refused, not fitted
    assert_refused(res, (where,), before, tmp_path, secret=SECRET)
    line = res.err.strip()
    if case != "port_file_missing":   # that one names the port file the model points to
        assert str(model) in line, line


def test_user_network_port_file_symlink_escape(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    ds, model = _user_case(tmp_path, _edit(PORT, ".port Zin in 0 impedance/link.csv"))
    (tmp_path / "secret.csv").write_text(f"{SECRET}\n")
    (ds / "impedance" / "link.csv").symlink_to(tmp_path / "secret.csv")
    before = snapshot(tmp_path)
    res = run_cli(capsys, ["diagnose", str(ds), "--model", str(model), "--out",
                           str(tmp_path / "out")])
    assert_refused(res, "outside the dataset", before, tmp_path, secret=SECRET)


# ---------------------------------------------------------------- predict: model netlist
def _net(old: str, new: str) -> str:
    assert old in GREYBOX_NETLIST
    return GREYBOX_NETLIST.replace(old, new, 1)


NETLIST_CASES: dict[str, str | bytes] = {
    "n_empty": "",
    "n_binary": b"\x00\x00R1 U 0 1",
    "n_zero_r": _net("R1 U 0 1k", "R1 U 0 0"),
    "n_negative_c": _net("C4 SN 0 1n", "C4 SN 0 -1n"),
    "n_inf_value": _net("R1 U 0 1k", "R1 U 0 1e999"),
    "n_nan_value": _net("R1 U 0 1k", "R1 U 0 nan"),
    "n_text_value": _net("R1 U 0 1k", "R1 U 0 big"),
    "n_duplicate_name": _net("R2 V 0 1k", "R2 V 0 1k\nR2 W 0 2k"),
    "n_duplicate_name_case": _net("R2 V 0 1k", "R2 V 0 1k\nr2 W 0 2k"),
    "n_unknown_card": _net(".end", ".frobnicate 1\n.end"),
    "n_subckt": _net(".end", ".subckt a 1 2\n.ends\n.end"),
    "n_include": _net(".end", ".include other.cir\n.end"),
    "n_instance": _net(".end", "X1 U V sub\n.end"),
    "n_diode": _net(".end", "D1 U V dmod\n.end"),
    "n_missing_sn": "* no SN\nR1 U 0 1k\nR2 V 0 1k\nR3 W 0 1k\n.end\n",
    "n_floating": _net(".end", "R9 a b 1\n.end"),
    "n_same_node": _net(".end", "R9 U U 1\n.end"),
    "n_too_few_fields": _net("R1 U 0 1k", "R1 U 0"),
    "n_k_unknown": _net(".end", "K1 L1 L2 0.5\n.end"),
    "n_k_too_large": _net(".end", "L1 U a 1u\nL2 a 0 1u\nK1 L1 L2 1.5\n.end"),
    "n_ac_phase": _net(".end", "V1 U 0 AC 1 90\n.end"),
    "n_model_json": '{"kind": "Z", "poles": []}\n',
    "n_2000_nodes": _net(".end", "".join(f"R{k}x n{k} n{k + 1} 1\nC{k}x n{k + 1} 0 1n\n"
                                        for k in range(2000)) + "R0y n0 0 1\n.end"),
}


@pytest.mark.parametrize("case", sorted(NETLIST_CASES))
def test_bad_predict_netlist(case: str, tmp_path: Path,
                             capsys: pytest.CaptureFixture[str]) -> None:
    model = tmp_path / ("model.json" if case == "n_model_json" else "network.cir")
    content = NETLIST_CASES[case]
    if isinstance(content, bytes):
        model.write_bytes(content)
    else:
        model.write_text(content)
    before = snapshot(tmp_path)
    res = run_cli(capsys, ["predict", str(model), "--inverter", "speed_rpm=100", "--out",
                           str(tmp_path / "out")])
    assert_refused(res, str(model), before, tmp_path)


# ---------------------------------------------------------------- predict: --inverter
OPTION_CASES: dict[str, tuple[str, str]] = {
    "f_sw_10": ("f_sw_hz=10", "f_sw_hz"),
    "fs_1e13": ("fs_hz=1e13", "fs_hz"),
    "fs_1e11_long": ("fs_hz=1e11", "samples"),
    "f_sw_0": ("f_sw_hz=0", "f_sw_hz"),
    "f_sw_negative": ("f_sw_hz=-8000", "f_sw_hz"),
    "f_sw_nan": ("f_sw_hz=nan", "f_sw_hz"),
    "f_sw_inf": ("f_sw_hz=inf", "f_sw_hz"),
    "n_periods_0": ("n_periods=0", "n_periods"),
    "n_periods_fraction": ("n_periods=2.5", "n_periods"),
    "n_periods_huge": ("n_periods=100000", "samples"),
    "pole_pairs_0": ("pole_pairs=0", "pole_pairs"),
    "speed_nan": ("speed_rpm=nan", "speed_rpm"),
    "speed_negative": ("speed_rpm=-5", "speed_rpm"),
    "v_dc_zero": ("v_dc=0", "v_dc"),
    "rise_longer_than_period": ("t_rise_s=1e-3", "t_rise_s"),
    "cable_r_zero": ("cable_r_ohm=0", "cable_r_ohm"),
    "cable_c_negative": ("cable_c_f=-1e-9", "cable_c_f"),
    "fs_below_band": ("fs_hz=1e6", "fs_hz"),
    "d_min_too_large": ("d_min=0.7", "d_min"),
    "unknown_key": ("frequency=8000", "frequency"),
    "duplicate_key": ("f_sw_hz=8000,f_sw_hz=9000", "f_sw_hz"),
    "missing_equals": ("f_sw_hz", "--inverter"),
    "not_a_number": ("f_sw_hz=fast", "f_sw_hz"),
    "empty_key": ("=5", "--inverter"),
    "hex_number": ("f_sw_hz=0x10", "f_sw_hz"),
}


@pytest.mark.parametrize("case", sorted(OPTION_CASES))
def test_bad_inverter_option(case: str, tmp_path: Path,
                             capsys: pytest.CaptureFixture[str]) -> None:
    opts, where = OPTION_CASES[case]
    model = tmp_path / "network.cir"
    model.write_text(GREYBOX_NETLIST)
    before = snapshot(tmp_path)
    t0 = time.perf_counter()
    res = run_cli(capsys, ["predict", str(model), "--inverter", opts, "--out",
                           str(tmp_path / "out")])
    assert time.perf_counter() - t0 < 5.0
    assert_refused(res, where, before, tmp_path)


@pytest.mark.parametrize("argv", [["--inverter", "v_dc=100", "REC"], []])
def test_predict_needs_one_excitation(argv: list[str], tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    model = tmp_path / "network.cir"
    model.write_text(GREYBOX_NETLIST)
    rec = tmp_path / "rec.npz"
    rec.write_bytes(b"")
    before = snapshot(tmp_path)
    argv = [str(rec) if a == "REC" else a for a in argv]
    res = run_cli(capsys, ["predict", str(model), *argv, "--out", str(tmp_path / "out")])
    assert_refused(res, "", before, tmp_path, one_line=False)


def test_predict_small_inverter_record_writes_all_outputs(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = tmp_path / "network.cir"
    model.write_text(GREYBOX_NETLIST)
    res = run_cli(capsys, ["predict", str(model), "--inverter",
                           "n_periods=1,fs_hz=2e7,f_sw_hz=2e5", "--out", str(tmp_path / "o")])
    assert res.code == 0, res.err
    names = sorted(p.name for p in (tmp_path / "o").iterdir())
    assert names == [".vfmodel-outputs", "prediction.json", "prediction.npz",
                     "prediction.png"]
    with np.load(tmp_path / "o" / "prediction.npz") as z:
        assert z["u_B"].size == 100          # 1 period at 20 MS/s and 200 kHz
