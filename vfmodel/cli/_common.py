"""Options and helpers shared by the CLI commands."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import click

from vfmodel.core.atomic import finite_json, write_json
from vfmodel.core.progress import no_progress

__all__ = [
    "finite_json",
    "out_option",
    "progress_bar",
    "quiet_option",
    "show_progress",
    "write_json",
]

quiet_option = click.option(
    "--quiet", "-q", is_flag=True, help="No progress output on stderr."
)
out_option = click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Output directory (created if missing).",
)


def show_progress(quiet: bool) -> bool:
    """Progress goes to stderr only when not quiet and stderr is a terminal."""
    return not quiet and sys.stderr.isatty()


class _Bars:
    """A tqdm bar per stage on stderr (the stage name is the bar's description)."""

    def __init__(self) -> None:
        self._bars: dict[str, Any] = {}

    def __call__(self, stage: str, done: int, total: int) -> None:
        from tqdm import tqdm

        bar = self._bars.get(stage)
        # a stage that starts again after its bar closed (the retries of a passivity
        # enforcement, one bar each) gets a new bar
        if bar is None or (bar.disable and done < total):
            # no monitor thread: identification forks worker processes only from a
            # process without threads (vfmodel.core.parallel)
            tqdm.monitor_interval = 0
            for other in self._bars.values():
                other.close()
            bar = tqdm(total=total, desc=stage, file=sys.stderr, leave=True,
                       dynamic_ncols=True)
            self._bars[stage] = bar
        bar.total = total
        bar.n = done
        bar.refresh()
        if done >= total:
            bar.close()

    def close(self) -> None:
        for bar in self._bars.values():
            bar.close()


def progress_bar(quiet: bool) -> Any:
    """The progress callback for a command: bars on a terminal, silent otherwise."""
    return _Bars() if show_progress(quiet) else no_progress
