"""The CLI's progress bars: a stage that starts again after its bar closed (each retry of a
passivity enforcement reports its programs under one stage name) gets a new bar instead
of updating the closed one, which tqdm no longer draws."""

from __future__ import annotations

import io
import sys

import pytest

from vfmodel.cli._common import _Bars


def test_a_restarted_stage_gets_a_new_bar(monkeypatch: pytest.MonkeyPatch) -> None:
    err = io.StringIO()
    monkeypatch.setattr(sys, "stderr", err)
    bars = _Bars()
    stage = "passivity enforcement (convex programs)"
    bars(stage, 0, 15)
    first = bars._bars[stage]
    bars(stage, 15, 15)                 # certified: the bar closes
    assert first.disable
    bars(stage, 0, 15)                  # a retry enforces again
    second = bars._bars[stage]
    assert second is not first and not second.disable
    bars(stage, 4, 15)
    bars.close()
    assert err.getvalue().count("4/15") >= 1
