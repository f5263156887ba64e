"""A convex program that Clarabel does not solve (SolverError) inside ``fit --passive`` is
one failed attempt, not an internal error: the retries go on, and when no attempt gives a
certificate the CLI exits 2 with the failure named. (A 24-pole model of scikit-rf's
wr1p5,line.s2p fitted to 4e-13 ended the relocation retry with "passivity program did not
end with status 'optimal'" and a traceback.)"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import pytest
import skrf

from tests._adversarial import run_cli
from vfmodel.errors import SolverError
from vfmodel.pipeline import fit_job
from vfmodel.pipeline.fit_job import run_fit

DELAY_SHORT = Path(skrf.__file__).parent / "data" / "delay_short.s1p"


def test_a_failed_program_leaves_the_retries(monkeypatch: pytest.MonkeyPatch) -> None:
    real = fit_job.enforce_passivity
    calls = []

    def first_fails(*args: Any, **kw: Any) -> Any:
        calls.append(1)
        if len(calls) == 1:
            raise SolverError("passivity program did not end with status 'optimal'")
        return real(*args, **kw)

    monkeypatch.setattr(fit_job, "enforce_passivity", first_fails)
    res = run_fit(DELAY_SHORT, passive=True, delay="auto")
    # the retries (out-of-band poles, README: delay_short 18x -> 0.98x) give the model
    assert len(calls) >= 2
    assert res.passivity is not None and res.passivity.passive
    floor = res.data_passivity.floor if res.data_passivity else 0.0
    assert res.rel_rms_error <= 1.2 * max(res.unconstrained_rel_rms_error, floor)


def test_every_program_failing_is_exit_2(tmp_path: Path, capsys: Any,
                                         monkeypatch: pytest.MonkeyPatch) -> None:
    def fails(*args: Any, **kw: Any) -> Any:
        raise SolverError("passivity program did not end with status 'optimal'")

    monkeypatch.setattr(fit_job, "enforce_passivity", fails)
    src = tmp_path / "delay_short.s1p"
    shutil.copy(DELAY_SHORT, src)
    out = tmp_path / "o"
    res = run_cli(capsys, ["fit", str(src), "--passive", "--no-plot", "--out", str(out)])
    assert res.code == 2, res.err
    assert "found no certificate" in res.err and "status 'optimal'" in res.err
    assert "Traceback" not in res.err
    assert not (out / "model.json").exists()


def test_failure_says_where_the_fit_violates(monkeypatch: pytest.MonkeyPatch) -> None:
    """The message of a failed enforcement describes the unconstrained model's violation
    and places its worst frequency against the data's band. Reference: the model of the
    same fit (vector_fit, same options) checked by check_passivity."""
    from vfmodel.errors import InputError
    from vfmodel.fitting import check_passivity, vector_fit

    def fails(*args: Any, **kw: Any) -> Any:
        raise SolverError("passivity program did not end with status 'optimal'")

    monkeypatch.setattr(fit_job, "enforce_passivity", fails)
    model, _ = vector_fit(DELAY_SHORT, delay="auto")
    ref = check_passivity(model)
    assert not ref.passive and ref.worst_freq_hz is not None
    net = skrf.Network(str(DELAY_SHORT))
    lo, hi = float(net.f[0]), float(net.f[-1])
    place = "above" if ref.worst_freq_hz > hi else "below" if ref.worst_freq_hz < lo \
        else "inside"
    with pytest.raises(InputError) as err:
        run_fit(DELAY_SHORT, passive=True, delay="auto")
    text = str(err.value)
    assert f"before enforcement the fitted model is {ref.describe()}" in text, text
    assert f"its worst violation {place} the data's band ({lo:.4g}-{hi:.4g} Hz)" in text
