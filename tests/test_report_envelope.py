"""Long traces are drawn from their run-wise extremes (vfmodel.report._mpl.envelope).

Reference: the trace itself; the reduced one must keep, in order, the smallest and the
largest sample of every run (what a line drawn at a pixel column's width shows)."""

from __future__ import annotations

import numpy as np

from vfmodel.report._mpl import envelope


def test_envelope_keeps_every_runs_extremes_in_order() -> None:
    rng = np.random.default_rng(4)
    t = np.arange(125_003) / 125e6
    y = np.cumsum(rng.standard_normal(t.size))
    xe, ye = envelope(t, y, n=2000)
    k = t.size // 2000                                     # 62 samples per run
    assert xe.size == 2 * 2000 + (t.size - 2000 * k)       # two per run, the tail kept
    assert np.all(np.diff(xe) > 0)                         # the samples' own order
    runs = y[: 2000 * k].reshape(2000, k)
    pairs = ye[: 4000].reshape(2000, 2)
    assert np.array_equal(np.sort(pairs, axis=1)[:, 0], runs.min(axis=1))
    assert np.array_equal(np.sort(pairs, axis=1)[:, 1], runs.max(axis=1))
    assert ye.max() == y.max() and ye.min() == y.min()


def test_short_trace_is_drawn_as_it_is() -> None:
    t = np.arange(3000.0)
    y = np.sin(t)
    xe, ye = envelope(t, y, n=2000)
    assert xe is t and ye is y
