"""The joint refit in ``reproduce`` (greybox.effects.JOINT_REFIT, issue 19): its option
reaches the identification, and the joint fit's intervals are widened by each quantity's
shift from the stage-wise fit (greybox.lsq.widen_interval)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from benches.small_dataset import make_small_dataset
from vfmodel.cli.main import main
from vfmodel.core.io_dataset import read_dataset
from vfmodel.greybox.effects import JOINT_REFIT
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


def test_shifted_interval_covers_both_fits() -> None:
    # a quantity that is 3 in the joint fit and 5 in the stage-wise one, with a narrow
    # interval of its own (std_log 0.01): the widened interval holds both values
    spec = [ParamSpec("a", 3.0, 1e-3, 1e3, "x")]
    joint, before = ParamSet.from_specs(spec), ParamSet.from_specs(spec).with_values({"a": 5.0})
    iv: dict[str, float | None] = {"value": 3.0, "lo": 3.0 * math.exp(-Z95 * 0.01),
                                   "hi": 3.0 * math.exp(Z95 * 0.01), "std_log": 0.01}
    out = rp._shifted(iv, lambda q: q["a"], joint, before)
    assert out["refit_shift_log"] == pytest.approx(math.log(5 / 3), rel=1e-12)
    assert out["lo"] is not None and out["hi"] is not None
    assert out["lo"] < 3.0 < 5.0 < out["hi"]
    # without a stage-wise fit (no joint stage kept) the interval is left as it is
    assert rp._shifted(iv, lambda q: q["a"], joint, None) is iv


class _Stop(Exception):
    pass


@pytest.mark.parametrize("flag", [None, "--no-joint", "--joint"])
def test_joint_option_reaches_the_identification(flag: str | None, tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    ds = tmp_path / "ds"
    make_small_dataset(ds)
    seen: dict[str, Any] = {}

    def fake_identify(*args: Any, **kw: Any) -> Any:
        seen.update(kw)
        raise _Stop

    monkeypatch.setattr(rp, "identify", fake_identify)
    # the library: the default and an explicit False
    with pytest.raises(_Stop):
        rp.reproduce(read_dataset(ds), blackbox=False)
    assert seen["joint"] is JOINT_REFIT and seen["joint_trigger"] == 0.0
    with pytest.raises(_Stop):
        rp.reproduce(read_dataset(ds), blackbox=False, joint=False)
    assert seen["joint"] is False
    # the CLI (the stopped run is an internal error, exit 1, and writes nothing)
    seen.clear()
    args = ["reproduce", str(ds), "--out", str(tmp_path / "out"), "--quiet"]
    assert main(args + ([flag] if flag else [])) == 1
    assert seen["joint"] is (JOINT_REFIT if flag is None else flag == "--joint")
    assert not (tmp_path / "out" / "results.json").exists()
    assert np.isfinite(seen["joint_trigger"])
