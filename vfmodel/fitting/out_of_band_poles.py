"""Real poles added out of band before passivity enforcement of S models.

Passivity enforcement with fixed poles (:mod:`vfmodel.fitting._enforce`) can only bend
the response out of band with the poles the fit found; when they all sit in or near the
band, an excursion above it (sigma(D) of 1.24 for a measured 1-port whose samples stay
below 0.92, or 1.0005 for a lossless line) is corrected by changing the band as well.
:func:`with_out_of_band_poles` adds real poles above and below the band with zero
residues: the enforcement program can then move D and the value at 0 Hz while keeping
the band (a step of size c through a pole p above the band, c p / (s + p) - c, changes
the band by only about c f / f_p). Measured with ``fit --passive`` (enforced error /
max(fit error, data floor)): ring slot measured.s1p 2.19 -> 1.00, line.s2p 93 -> 1.1,
delay_short.s1p 18 -> 0.98, ntwk1.s2p 1.41 -> 1.01.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vfmodel.core.rational_model import RationalModel

_ABOVE = (3.0, 10.0, 30.0)  # added real poles / highest data frequency
_BELOW = (1.0 / 3.0, 0.1)  # added real poles / lowest positive data frequency


def with_out_of_band_poles(model: RationalModel, f_hz: NDArray[np.float64]) -> RationalModel:
    """``model`` with real poles above and below the data band ``f_hz`` (Hz) added with
    zero residues (the response is unchanged; module docstring). No pole is added below
    a band that starts at 0 Hz, nor one the model already has (an enforced model that got
    them before: a repeated pole makes the enforcement's basis singular)."""
    pos = f_hz[f_hz > 0]
    if pos.size == 0:
        return model
    above = [-2 * np.pi * pos[-1] * x for x in _ABOVE]
    below = [] if f_hz[0] == 0 else [-2 * np.pi * pos[0] * x for x in _BELOW]
    new = np.asarray(above + below, dtype=complex)
    new = new[~np.any(np.isclose(new[:, None], model.poles[None], rtol=1e-9, atol=0.0),
                      axis=1)]
    zeros = np.zeros((new.size, model.n_out, model.n_in), dtype=complex)
    return RationalModel(np.concatenate([model.poles, new]),
                         np.concatenate([model.residues, zeros]), model.dd, model.ee,
                         model.kind, model.z0, delay=model.delay)
