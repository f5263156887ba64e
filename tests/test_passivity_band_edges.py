"""Violation bands whose polished edges changed order (crossings within 1e-7 of each other)
are merged into ordered bands. A 67-pole fit of a COMSOL microstrip export (unseen file,
solarcell1475/hfss-microstrip-results) had the bands (7381070048, 7381071390) and
(7381071390, 7381070870) rad/s after polishing, and ``check_passivity`` raised scipy's
"The lower bound exceeds the upper bound" (an internal error of ``fit --passive``)."""

from __future__ import annotations

import numpy as np

from vfmodel import RationalModel
from vfmodel.fitting.passivity import _merged, _worst


def test_inverted_and_touching_bands_are_merged() -> None:
    bands = [(5.0, 6.0), (7381070048.6, 7381071389.9), (7381071389.9, 7381070870.5),
             (1.0, 2.0), (2.0, 3.0), (8.0, 9.0)]
    assert _merged(bands) == [(1.0, 3.0), (5.0, 6.0), (8.0, 9.0),
                              (7381070048.6, 7381071389.9)]


def test_worst_over_merged_bands() -> None:
    # a 1-port S model with |S| = 2 at 0 Hz falling to 0 above the pole: violated from DC
    # to the crossing sqrt(3) rad/s (|S| = 1); reference: the closed form 2 / |1 + j w|
    model = RationalModel(np.array([-1.0 + 0j]), np.array([[[2.0 + 0j]]]), kind="S")
    bands = _merged([(0.5, 1.0), (1.0, 0.2), (1.0, np.sqrt(3.0))])
    assert bands == [(0.2, np.sqrt(3.0))]
    worst, where = _worst(model, bands)
    assert where is not None
    assert abs(worst - (2.0 / abs(1 + 0.2j) - 1.0)) < 1e-6
