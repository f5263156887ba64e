"""Out-of-band control of S fits: how strongly the anchors and the ridge of the residue
solve (:class:`vfmodel.fitting._vf_core.Problem`) act, and a check that the fitted model
stays of the size of the data outside the band.

Strength: the anchors are pseudo-measurements saying only "outside the band the response
is of the size of the data at the nearer edge"; weighed against measurements whose
relative noise is ``noise``, such a prior deserves a relative weight of about ``noise``
(a regression's ridge likewise scales with the noise variance). A fixed weight (1e-4)
cost noise-free data (simulations, 1e-10 noise) accuracy at the 1e-7-1e-6 level, far
above what the data support. The anchor weight and the ridge are therefore scaled by
``noise / 1e-4``, clipped to [1e-6, 1]: measured data (noise >= 1e-4) keep the former
weights, noise-free data get almost none.

Check: a weakly anchored model can still leave the data's size out of band (a D of
sigma 27 for an 8-port PDN whose data never exceed 1), which passivity enforcement can
only repair by distorting the band. When the largest singular value at the anchor
frequencies or of D exceeds twice the data's largest (at least 1) -- a gross excursion;
smaller ones the enforcement repairs at little cost -- the residues are solved again,
poles fixed, with anchors of relative weight 1e-4 (the former fixed weight), 1e-3, 1e-2
and 0.1 (the strongest weight the enforcement retries use) until it is bounded, as long
as the in-band error stays within 2.5 times the fit's; otherwise the fit is kept.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from vfmodel.fitting import _vf_core as core

_NOISE_REF = 1e-4  # noise level at which the anchors and the ridge have their full weight
_MIN_SCALE = 1e-6  # the weakest scaling (noise-free data)
_EXCURSION = 2.0  # allowed out-of-band gain relative to max(1, the data's largest)
_STRONGER = (1e-4, 1e-3, 1e-2, 1e-1)  # anchor weights (relative) tried in turn
_COST = 2.5  # ... as long as the in-band error stays within this factor of the fit's


def strength(noise: float) -> float:
    """Scaling of the anchor weight and the ridge for data of relative noise ``noise``."""
    return float(np.clip(noise / _NOISE_REF, _MIN_SCALE, 1.0))


def _out_of_band_gain(prob: core.Problem, coef: core.Coefficients, n: int) -> float:
    """Largest singular value of the model at the anchor frequencies and of D."""
    assert prob.anchors is not None
    s_v = prob.anchors[0]
    h = core.partial_fractions(s_v, coef.reps) @ coef.c.T + coef.d[None, :]
    if prob.fit_e:
        h = h + s_v[:, None] * coef.e[None, :]
    mats = np.concatenate([h.reshape(-1, n, n), coef.d.reshape(1, n, n)], axis=0)
    return float(np.max(np.linalg.svd(mats, compute_uv=False)))


def bounded(
    prob: core.Problem,
    coef: core.Coefficients,
    make_anchors: Callable[[float], core.Anchors | None],
    n_ports: int,
) -> tuple[core.Problem, core.Coefficients]:
    """The problem and coefficients with the out-of-band gain checked (module doc).

    ``make_anchors(rel_weight)`` gives the anchors of that relative weight."""
    if prob.anchors is None or coef.c.shape[0] != n_ports * n_ports:
        return prob, coef
    data = prob.h.reshape(-1, n_ports, n_ports)
    limit = _EXCURSION * max(1.0, float(np.max(np.linalg.svd(data, compute_uv=False))))
    if _out_of_band_gain(prob, coef, n_ports) <= limit:
        return prob, coef
    current = prob.anchors[2]
    err0 = core.weighted_rel_rms(prob, core.evaluate(prob, coef))
    for rel in _STRONGER:
        anchors = make_anchors(rel)
        if anchors is None or anchors[2] <= current:
            continue
        trial = replace(prob, anchors=anchors)
        c_trial = core.solve_residues(trial, coef.reps)
        if core.weighted_rel_rms(trial, core.evaluate(trial, c_trial)) > _COST * err0:
            break  # stronger anchors only cost more
        if _out_of_band_gain(trial, c_trial, n_ports) <= limit:
            return trial, c_trial
    return prob, coef
