"""Progress reporting without global state: long computations take a ``progress`` callback.

Numerical code calls ``progress(stage, done, total)``; the CLI passes a terminal progress
bar (:func:`vfmodel.cli._common.progress_bar`), library users pass their own or nothing.
"""

from __future__ import annotations

from typing import Protocol


class Progress(Protocol):
    """Callback ``progress(stage, done, total)``: ``done`` of ``total`` steps of ``stage``."""

    def __call__(self, stage: str, done: int, total: int) -> None: ...


def no_progress(stage: str, done: int, total: int) -> None:
    """The default callback: report nothing."""
