"""Options and helpers shared by the CLI commands."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import click

from vfmodel.core.atomic import atomic_write_text

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


def write_json(path: Path, obj: Any) -> None:
    """Write ``obj`` as indented JSON, atomically."""
    atomic_write_text(path, json.dumps(obj, indent=2, allow_nan=False) + "\n")
