"""Options and helpers shared by the CLI commands."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

import click

from vfmodel.core.atomic import atomic_write_text
from vfmodel.core.progress import no_progress

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


def finite_json(obj: Any) -> Any:
    """``obj`` with every non-finite float (inf, -inf, NaN) replaced by ``None``.

    Strict JSON has no infinity or NaN; vfmodel writes ``null`` for such a number (README,
    "Output files": an unbounded significance, a band reaching infinity, a value that
    could not be computed).
    """
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite_json(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [finite_json(v) for v in obj]
    if hasattr(obj, "dtype") and hasattr(obj, "tolist"):  # numpy scalar or array
        return finite_json(obj.tolist())
    return obj


def write_json(path: Path, obj: Any) -> None:
    """Write ``obj`` as indented strict JSON (non-finite numbers as null), atomically."""
    atomic_write_text(path, json.dumps(finite_json(obj), indent=2, allow_nan=False) + "\n")


class _Bars:
    """A tqdm bar per stage on stderr (the stage name is the bar's description)."""

    def __init__(self) -> None:
        self._bars: dict[str, Any] = {}

    def __call__(self, stage: str, done: int, total: int) -> None:
        from tqdm import tqdm

        bar = self._bars.get(stage)
        if bar is None:
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
