"""The time limit of the enforcement retries of ``fit --passive`` (run_fit and CLI)."""

from __future__ import annotations

import inspect
import json
import shutil
from pathlib import Path

import pytest
import skrf

from tests._adversarial import run_cli
from vfmodel.cli.cmd_fit import fit
from vfmodel.errors import InputError
from vfmodel.fitting.defaults import ENFORCE_TIME_LIMIT
from vfmodel.pipeline.fit_job import run_fit

DELAY_SHORT = Path(skrf.__file__).parent / "data" / "delay_short.s1p"


def test_time_limit_default_is_one_constant() -> None:
    job = inspect.signature(run_fit).parameters["enforce_time_limit"].default
    cli = next(p.default for p in fit.params if p.name == "enforce_time_limit")
    assert job == cli == ENFORCE_TIME_LIMIT


def test_retries_stop_at_the_time_limit_and_say_so(recwarn) -> None:  # type: ignore[no-untyped-def]
    # scikit-rf's delay_short.s1p: the first enforcement ends beyond 1.2x the fit error,
    # the out-of-band-poles retry brings it within (README: 18x -> 0.98x). Reference: the
    # bound 1.2 max(fit error, data floor) of run_fit
    full = run_fit(DELAY_SHORT, passive=True, delay="auto")
    floor = full.data_passivity.floor if full.data_passivity else 0.0
    bound = 1.2 * max(full.unconstrained_rel_rms_error, floor)
    assert full.passivity is not None and full.passivity.passive
    assert full.rel_rms_error <= bound
    assert not [n for n in full.fit.notes if "time limit" in n]
    # a limit already past when the retries start: none runs, the first enforcement is
    # kept (passive, beyond the bound) and a note names the limit
    cut = run_fit(DELAY_SHORT, passive=True, delay="auto", enforce_time_limit=1e-9)
    assert cut.passivity is not None and cut.passivity.passive
    assert cut.rel_rms_error > bound
    assert [n for n in cut.fit.notes if "stopped at the time limit" in n]


def test_cli_option(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    src = tmp_path / "delay_short.s1p"
    shutil.copy(DELAY_SHORT, src)
    res = run_cli(capsys, ["fit", str(src), "--passive", "--enforce-time-limit", "1e-9",
                           "--no-plot", "--out", str(tmp_path / "o")])
    assert res.code == 0, res.err
    assert "stopped at the time limit" in res.err
    doc = json.loads((tmp_path / "o" / "model.json").read_text())
    assert any("stopped at the time limit" in n for n in doc["fit_notes"])
    bad = run_cli(capsys, ["fit", str(src), "--enforce-time-limit", "-1",
                           "--out", str(tmp_path / "p")])
    assert bad.code == 2 and "--enforce-time-limit" in bad.err
    nan = run_cli(capsys, ["fit", str(src), "--enforce-time-limit", "nan",
                           "--out", str(tmp_path / "q")])
    assert nan.code == 2 and "--enforce-time-limit" in nan.err
    assert not (tmp_path / "q").exists()


def test_negative_limit_refused() -> None:
    with pytest.raises(InputError, match="enforce_time_limit"):
        run_fit(DELAY_SHORT, passive=True, enforce_time_limit=-5.0)
