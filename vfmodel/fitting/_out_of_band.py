"""Lighter out-of-band control of S fits once the poles are found.

The anchors and the ridge of the residue solve (:class:`vfmodel.fitting._vf_core.Problem`)
keep an S model of the data's size outside the band while its poles are relocated. Their
fixed weights (anchors 1e-4 of the median data weight, ridge 1e-7) also cap the in-band
accuracy near 1e-7-1e-6, which on noise-free files (simulations) is far above what the
data support and what scikit-rf reaches with the same order (e.g. ntwk1.s2p: 8.1e-8
against 5.8e-10, open.s2p 8.6e-7 against 1.2e-10).

Once the automatic order (or the given order) is reached, the poles are relocated once
more at that order, from where they are, with both weights scaled down by 1e-6 (the
order decision of the growth stays as it is); when kept, this relocation replaces the
automatic order's final one (``auto_order(finish=)``); below the anchored cap it comes
before the one-pole-less trials, which then run only when it is not kept. It is tried
only when the anchored fit's weighted error is below 1e-5, and kept only when it cuts
the weighted error by at least ``_GAIN`` and its out-of-band gain -- the largest
singular value at 0 Hz, at the anchor frequencies and of D -- does not exceed the
anchored fit's (or the data's largest, or 1) by more than ``_SLACK``: measured data,
whose error is the noise, keep the anchored fit, and a lighter fit that leaves the
data's size out of band (coaxial.s2p: a gain of 2.5 against 1.0016) is not taken.
Measured (poles relocated, 1-18 iterations, 1-6 ms): ntwk1.s2p 8.1e-8 -> 5.9e-10,
open.s2p 8.6e-7 -> 3.2e-10, short.s2p 8.3e-8 -> 4.8e-9, line.s2p 1.0e-7 -> 6.7e-8
with sigma(D) 1.0088 -> 1.0005.
"""

from __future__ import annotations

import numpy as np

from vfmodel.fitting import _relocate
from vfmodel.fitting import _vf_core as core

_SCALE = 1e-6  # scaling of the anchor weight and of the ridge
_GAIN = 1.25  # the lighter fit must cut the weighted error by at least this factor
_SLACK = 1e-3  # ... and keep its out-of-band gain within this of the reference
# tried only below this weighted error: the anchors and the ridge cap the accuracy near
# 1e-7-3e-6, measured data stay above 1e-4 (the 8-port PDN's 1e-4 noise: a relocation
# of 93 poles for nothing, 9 s)
_TRY_BELOW = 1e-5


def _gain(prob: core.Problem, coef: core.Coefficients, n: int) -> float:
    """Largest singular value of the model at 0 Hz, at the anchor frequencies and of D."""
    s_v = np.zeros(1, complex)
    if prob.anchors is not None:
        s_v = np.concatenate([s_v, prob.anchors[0]])
    h = core.partial_fractions(s_v, coef.reps) @ coef.c.T + coef.d[None, :]
    if prob.fit_e:
        h = h + s_v[:, None] * coef.e[None, :]
    mats = np.concatenate([h.reshape(-1, n, n), coef.d.reshape(1, n, n)], axis=0)
    return float(np.max(core.singular_values(mats)))


def lighter(
    prob: core.Problem, coef: core.Coefficients, n_ports: int, *,
    max_iterations: int, tol: float, stable: bool,
) -> tuple[core.Problem, core.FixedOrderResult] | None:
    """The problem with the lighter out-of-band control (module doc) and the relocation
    at ``coef``'s order in it, or None when it is not tried or not kept."""
    if (prob.anchors is None and prob.ridge == 0.0) or coef.c.shape[0] != n_ports**2 \
            or coef.c.shape[1] == 0:
        return None
    err0 = core.weighted_rel_rms(prob, core.evaluate(prob, coef))
    if not err0 <= _TRY_BELOW:
        return None
    data = prob.h.reshape(-1, n_ports, n_ports)
    top = float(np.max(core.singular_values(data)))
    limit = max(_gain(prob, coef, n_ports), top, 1.0) + _SLACK
    anchors = prob.anchors
    trial = prob.with_out_of_band(prob.ridge * _SCALE,
                                  None if anchors is None else anchors[2] * _SCALE)
    # kept only when it reaches err0 / _GAIN: given up once it cannot (iterate's target)
    res = _relocate.iterate(trial, coef.reps, max_iterations=max_iterations, tol=tol,
                            stable=stable, target=err0 / _GAIN)
    err = res.weighted_rel_rms
    if np.isfinite(err) and err * _GAIN <= err0 and _gain(trial, res.coef, n_ports) <= limit:
        return trial, res
    return None
