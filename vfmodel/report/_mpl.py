"""Lazy matplotlib import with the non-interactive Agg backend."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vfmodel.core.atomic import atomic_path


def pyplot() -> Any:
    """``matplotlib.pyplot`` on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save(fig: Any, path: Path, dpi: int = 120) -> None:
    """Save a figure atomically as PNG and close it."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png", bbox_inches="tight")
    pyplot().close(fig)


def draw_side_by_side(jobs: Sequence[Callable[[], list[str]]]) -> list[str]:
    """Run figure jobs (each draws and saves its figures, returns their file names) side by
    side where :func:`vfmodel.core.parallel.parallel_calls` can; matplotlib is imported
    here first, so that the forked processes inherit it instead of importing it each.
    Returns every file name, in job order."""
    from vfmodel.core.parallel import parallel_calls

    pyplot()
    return [name for names in parallel_calls(jobs) for name in names]


ENVELOPE_POINTS = 2000
"""Runs of samples a long trace is reduced to (two per pixel column of a 1000-pixel-wide
plot)."""


def envelope(x: NDArray[np.float64], y: NDArray[np.float64], n: int = ENVELOPE_POINTS
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(x, y)`` of a long trace reduced to the smallest and the largest sample of each of
    ``n`` equal runs, in their order (samples after the last whole run kept): drawn as a
    line at a figure's width the same picture, at a fraction of the drawing time
    (a 125,000-sample record: ~1 s per figure). Short traces are returned as they are."""
    m = y.size
    if m <= 2 * n:
        return x, y
    k = m // n
    yb = y[: n * k].reshape(n, k)
    lo, hi = yb.argmin(axis=1), yb.argmax(axis=1)
    idx = (np.stack([np.minimum(lo, hi), np.maximum(lo, hi)], axis=1)
           + (np.arange(n) * k)[:, None]).ravel()
    idx = np.concatenate([idx, np.arange(n * k, m)])
    return x[idx], y[idx]
