"""The joint refit in ``reproduce`` (greybox.effects.JOINT_REFIT, issue 19): its option
reaches the identification, and the joint fit's intervals are widened by each quantity's
shift from the stage-wise fit (greybox.lsq.widen_interval)."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray

from benches.small_dataset import make_small_dataset
from tests.conftest import load_script
from vfmodel.cli.main import main
from vfmodel.core.io_dataset import read_dataset
from vfmodel.greybox.assembly import lubricant_names
from vfmodel.greybox.effects import JOINT_REFIT
from vfmodel.greybox.identify import identify
from vfmodel.greybox.joint import SHARED
from vfmodel.greybox.lsq import widen_interval
from vfmodel.greybox.params import ParamSet, ParamSpec
from vfmodel.pipeline import reproduce as rp

Z95 = 1.959964


def test_widened_interval_adds_the_shift_in_quadrature() -> None:
    # std_log 0.3 and a shift of 0.4 (the quantity moved by e^0.4 between the two fits):
    # std_log 0.5, bounds value * exp(-+1.96 * 0.5)
    iv: dict[str, float | None] = {"value": 2.0, "lo": 2.0 * math.exp(-Z95 * 0.3),
                                   "hi": 2.0 * math.exp(Z95 * 0.3), "std_log": 0.3}
    out = widen_interval(iv, 0.4)
    assert out["std_log"] == pytest.approx(0.5, rel=1e-12)
    assert out["lo"] == pytest.approx(2.0 * math.exp(-Z95 * 0.5), rel=1e-12)
    assert out["hi"] == pytest.approx(2.0 * math.exp(Z95 * 0.5), rel=1e-12)
    assert out["refit_shift_log"] == 0.4 and out["value"] == 2.0
    assert iv["std_log"] == 0.3   # the input is not changed
    # no shift: the interval as it was
    same = widen_interval(iv, 0.0)
    assert same["lo"] == pytest.approx(iv["lo"], rel=1e-12)
    # an unbounded interval stays unbounded; an infinite shift leaves no bound (strict JSON)
    assert widen_interval({"value": 1.0, "lo": None, "hi": None, "std_log": None},
                          0.2)["lo"] is None
    gone = widen_interval(iv, float("inf"))
    assert gone["lo"] is None and gone["hi"] is None and gone["refit_shift_log"] is None
    json.dumps(gone, allow_nan=False)


@dataclass(frozen=True)
class _Report:
    names: tuple[str, ...]
    cov_log: NDArray[np.float64] | None


def test_joint_interval_covers_both_fits() -> None:
    # a quantity that is 3 in the joint fit (std_log 0.01 from its covariance) and 5 in the
    # stage-wise one: the widened interval holds both values, std_log hypot(0.01, log 5/3)
    spec = [ParamSpec("a", 3.0, 1e-3, 1e3, "x")]
    joint, before = ParamSet.from_specs(spec), ParamSet.from_specs(spec).with_values({"a": 5.0})
    rep = _Report(("a",), np.array([[0.01**2]]))
    out = rp._interval(joint, rep, lambda q: q["a"], before=before)
    assert out["refit_shift_log"] == pytest.approx(math.log(5 / 3), rel=1e-9)
    assert out["std_log"] == pytest.approx(math.hypot(0.01, math.log(5 / 3)), rel=1e-6)
    assert out["lo"] is not None and out["hi"] is not None
    assert out["lo"] < 3.0 < 5.0 < out["hi"]
    # without a stage-wise fit (no joint stage kept): log_interval's own interval
    plain = rp._interval(joint, rep, lambda q: q["a"], before=None)
    assert "refit_shift_log" not in plain
    assert plain["std_log"] == pytest.approx(0.01, rel=1e-6)


class _Stop(Exception):
    pass


def test_library_joint_default_reaches_the_identification(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    ds = tmp_path / "ds"
    make_small_dataset(ds)
    seen = _stopped_identify(monkeypatch)
    with pytest.raises(_Stop):
        rp.reproduce(read_dataset(ds), blackbox=False)
    assert seen["joint"] is JOINT_REFIT and seen["joint_trigger"] == 0.0
    with pytest.raises(_Stop):
        rp.reproduce(read_dataset(ds), blackbox=False, joint=not JOINT_REFIT)
    assert seen["joint"] is (not JOINT_REFIT)


@pytest.mark.parametrize("flag", [None, "--no-joint", "--joint"])
def test_cli_joint_option_reaches_the_identification(flag: str | None, tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    ds = tmp_path / "ds"
    make_small_dataset(ds)
    seen = _stopped_identify(monkeypatch)
    # the stopped run is an internal error (exit 1) and writes nothing
    args = ["reproduce", str(ds), "--out", str(tmp_path / "out"), "--quiet"]
    assert main(args + ([flag] if flag else [])) == 1
    assert seen["joint"] is (JOINT_REFIT if flag is None else flag == "--joint")
    assert seen["joint_trigger"] == 0.0
    assert not (tmp_path / "out" / "results.json").exists()


def _stopped_identify(monkeypatch: pytest.MonkeyPatch) -> dict[str, Any]:
    """Replace reproduce's identify by one that records its arguments and stops."""
    seen: dict[str, Any] = {}

    def fake_identify(*args: Any, **kw: Any) -> Any:
        seen.update(kw)
        raise _Stop

    monkeypatch.setattr(rp, "identify", fake_identify)
    return seen


def test_identify_keeps_the_stagewise_values_of_a_kept_joint_fit(tmp_path: Path) -> None:
    """When the joint stage is kept, ``Identification.stagewise`` holds the values before it:
    the machine (key None) and each rotating speed's parameters, as the stage-wise fit left
    them. The bench of tests/test_reproduce.py, on which the joint fit is kept (session 23).
    The joint stage refits only the shared rotor-side values and the per-speed lubricant,
    so every other machine value is the stage-wise one and at least one shared value moved.
    """
    ds = tmp_path / "bench"
    load_script("make_testbench").make_bench(ds, seed=2, speeds=(0.0, 200.0), periods=1,
                                             n_freq=81, n_coils=2, n_rungs=4)
    data = read_dataset(ds)
    plain = identify(data, sections=(2,), max_nfev=12, joint=False)
    ident = identify(data, sections=(2,), max_nfev=12, joint=True, joint_trigger=0.0)
    assert plain.stagewise == {}
    assert any(st.name.startswith("joint") for st in ident.stages), "joint fit not kept"
    assert set(ident.stagewise) == {None, 200.0}
    before = ident.stagewise[None]
    # the values before the joint stage are the stage-wise fit's: same data and code in one
    # process (measured identical; 1e-12 leaves room for rounding only)
    assert before.names == plain.params.names
    np.testing.assert_allclose(before.values, plain.params.values, rtol=1e-12)
    shared = [n for n in SHARED if n in before.names]
    for n in before.names:
        if n not in shared:
            assert ident.params[n] == pytest.approx(before[n], rel=1e-12), n
    assert max(abs(math.log(ident.params[n] / before[n])) for n in shared) > 1e-3
    rot_plain = next(f for f in plain.speeds if f.speed_rpm == 200.0)
    rot_joint = next(f for f in ident.speeds if f.speed_rpm == 200.0)
    lub = lubricant_names(before)
    np.testing.assert_allclose([ident.stagewise[200.0][n] for n in lub],
                               [rot_plain.params[n] for n in lub], rtol=1e-12)
    assert any(rot_joint.params[n] != ident.stagewise[200.0][n] for n in lub)
