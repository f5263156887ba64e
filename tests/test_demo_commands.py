"""``make demo`` runs every stage: the lazily loaded CLI commands are seen."""

from __future__ import annotations

import importlib.util
from pathlib import Path


def test_demo_sees_fit_and_reproduce() -> None:
    path = Path(__file__).resolve().parents[1] / "scripts" / "demo.py"
    spec = importlib.util.spec_from_file_location("vfmodel_demo", path)
    assert spec is not None and spec.loader is not None
    demo = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(demo)
    # reference: the commands of CONTRACT section 3 the demo runs
    assert {"info", "convert", "fit", "reproduce"} <= demo.available_commands()
