"""The time limit of passivity enforcement in ``fit --passive`` (run_fit and CLI) and of
``enforce_passivity(time_limit=)``."""

from __future__ import annotations

import inspect
import json
import shutil
from pathlib import Path

import pytest
import skrf

from tests._adversarial import run_cli
from vfmodel.cli.cmd_fit import fit
from vfmodel.errors import InputError, PassivityError
from vfmodel.fitting import enforce_passivity, vector_fit
from vfmodel.fitting.defaults import ENFORCE_TIME_LIMIT
from vfmodel.pipeline import fit_job
from vfmodel.pipeline.fit_job import run_fit

DELAY_SHORT = Path(skrf.__file__).parent / "data" / "delay_short.s1p"


def test_time_limit_default_is_one_constant() -> None:
    job = inspect.signature(run_fit).parameters["enforce_time_limit"].default
    cli = next(p.default for p in fit.params if p.name == "enforce_time_limit")
    assert job == cli == ENFORCE_TIME_LIMIT


class _PassesAfterFirst(fit_job._EnforceClock):
    """A clock whose limit passes right after the first enforcement: no limit inside it,
    none left when the retries ask (deterministic, unlike a wall-clock limit)."""

    def __init__(self, limit: float | None, hold: float = 0.0) -> None:
        super().__init__(limit, hold)
        self.asked = False

    def out(self) -> bool:
        self.asked = self.stopped = True
        return True

    def remaining(self) -> float | None:
        return 0.0 if self.asked else None


def test_retries_stop_at_the_time_limit_and_say_so(recwarn, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    # scikit-rf's delay_short.s1p: the first enforcement ends beyond 1.2x the fit error,
    # the out-of-band-poles retry brings it within (README: 18x -> 0.98x). Reference: the
    # bound 1.2 max(fit error, data floor) of run_fit
    full = run_fit(DELAY_SHORT, passive=True, delay="auto")
    floor = full.data_passivity.floor if full.data_passivity else 0.0
    bound = 1.2 * max(full.unconstrained_rel_rms_error, floor)
    assert full.passivity is not None and full.passivity.passive
    assert full.rel_rms_error <= bound
    assert not [n for n in full.fit.notes if "time limit" in n]
    # the limit passes when the retries start: none runs, the first enforcement is kept
    # (passive, beyond the bound) and a note names the limit
    monkeypatch.setattr(fit_job, "_EnforceClock", _PassesAfterFirst)
    cut = run_fit(DELAY_SHORT, passive=True, delay="auto")
    assert cut.passivity is not None and cut.passivity.passive
    assert cut.rel_rms_error > bound
    assert [n for n in cut.fit.notes if "stopped at the time limit" in n]


def test_limit_covers_the_first_enforcement() -> None:
    # a limit already past: the first enforcement stops after its first convex program,
    # so either that program was certified or run_fit says no model was certified in time
    try:
        cut = run_fit(DELAY_SHORT, passive=True, delay="auto", enforce_time_limit=1e-9)
    except InputError as err:
        assert "within the time limit" in str(err) and "--enforce-time-limit" in str(err)
    else:
        assert cut.passivity is not None and cut.passivity.iterations == 1


@pytest.mark.filterwarnings("ignore::vfmodel.errors.FitWarning")  # beyond 1.2x: no retries
def test_limit_covers_models_without_retries(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    # models that get no retries (S of more than _RETRY_PORTS ports; Z, Y) had no limit:
    # an 8-port model of coupled lines ran 30 programs past 16 minutes. With no retries
    # for any port count, a limit already past stops the first enforcement after its first
    # program: certified by it (1 program) or the time-limit error; the old code ran every
    # program (the full enforcement takes more than one, asserted first)
    monkeypatch.setattr(fit_job, "_RETRY_PORTS", 0)
    full = run_fit(DELAY_SHORT, passive=True, delay="auto")
    assert full.passivity is not None and full.passivity.iterations > 1
    try:
        cut = run_fit(DELAY_SHORT, passive=True, delay="auto", enforce_time_limit=1e-9)
    except InputError as err:
        assert "within the time limit" in str(err) and "--enforce-time-limit" in str(err)
    else:
        assert cut.passivity is not None and cut.passivity.iterations == 1


def test_enforce_passivity_time_limit() -> None:
    model = vector_fit(DELAY_SHORT, delay="auto")[0]
    full = enforce_passivity(model, DELAY_SHORT)[1]
    assert full.passive and full.iterations > 1  # so that a limit of 0 must cut it
    with pytest.raises(PassivityError, match="time limit passed \\(1 convex programs completed"):
        enforce_passivity(model, DELAY_SHORT, time_limit=0.0)
    for bad in (-1.0, float("nan")):
        with pytest.raises(InputError, match="time_limit"):
            enforce_passivity(model, DELAY_SHORT, time_limit=bad)


def test_cli_option(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    src = tmp_path / "delay_short.s1p"
    shutil.copy(DELAY_SHORT, src)
    res = run_cli(capsys, ["fit", str(src), "--passive", "--enforce-time-limit", "1e-9",
                           "--no-plot", "--out", str(tmp_path / "o")])
    if res.code == 0:  # the first program was certified (test above): a note says so
        doc = json.loads((tmp_path / "o" / "model.json").read_text())
        assert any("stopped at the time limit" in n for n in doc["fit_notes"])
    else:
        assert res.code == 2 and "--enforce-time-limit" in res.err, res.err
        assert not (tmp_path / "o").exists()
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
