"""The passive model nearest the data at given poles, through the enforcement's own program.

Passivity enforcement (:mod:`vfmodel.fitting._enforce`) minimises the change of the
response from the model it is given, f(x) = ||A (x - x_s)||^2 + ||T (x - x_s)||^2 (A: the
weighted basis on the data frequencies, T: a small Tikhonov term). When x_s is the
fit's least-squares solution that change is the distance to the data up to a constant.
Pole relocation (:mod:`vfmodel.fitting.passive_relocation`) hands the enforcement a fit
to the data *and* to passive targets out of band, whose residues are not the data's
least squares at its poles, so the enforced model is the passive model nearest that
fit, not nearest the data.

:func:`centred_on_data` gives the start x_s that makes the enforcement's objective the
data's: the minimiser of ||A x - y||^2 + ||T (x - x_0)||^2, with y the weighted data and
x_0 a passive model with these poles (its residues, zeros for poles it lacks). For a
quadratic, ||A x - y||^2 + ||T (x - x_0)||^2 = const + ||A (x - x_s)||^2 + ||T (x - x_s)||^2,
so enforcing x_s minimises the data distance plus the Tikhonov pull towards the passive
x_0 over all passive models with these poles; x_0 itself is one of them, so the result
is at most as far from the data as x_0 (up to the enforcement's margin).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.rational_model import RationalModel
from vfmodel.fitting._enforce import (
    _entry_systems,
    _response,
    _response_scale,
    _tikhonov,
    _to_residues,
)

FloatArray = NDArray[np.float64]


def centred_on_data(model: RationalModel, data: FrequencyData, *, weighting: str,
                    perturb_d: bool = True) -> RationalModel:
    """The model with the poles of ``model`` minimising the enforcement's objective with
    the data as its centre and the Tikhonov term centred at ``model`` (module docstring).
    ``model`` (an S, Z or Y model of ``data``'s kind, delay allowed): passive, e.g. an
    enforced model with poles added at zero residues. ``weighting``: the enforcement's
    ("uniform" or "relative")."""
    n = model.n_in
    f = data.freq_hz
    rational = model.without_delay() if model.delay else model
    target = data.values * np.exp(2j * np.pi * f * model.delay)[:, None, None] \
        if model.delay else data.values
    h0 = _response_scale(model.kind, target)
    col, systems, weights = _entry_systems(rational, f, target, weighting, perturb_d, h0)
    gap = target - _response(rational, f)  # what the change should add, per entry
    # entries with the same weights share their system: one solve for all of them
    # (uniform weighting: one for the whole matrix)
    groups: dict[int, list[int]] = {}
    for k, a_ri in enumerate(systems):
        groups.setdefault(id(a_ri), []).append(k)
    x = np.zeros((col.size, n, n))
    for ks in groups.values():
        a_ri = systems[ks[0]]
        rhs = np.zeros((a_ri.shape[0] + col.size, len(ks)))
        for m, k in enumerate(ks):
            g = gap[:, k // n, k % n]
            rhs[: a_ri.shape[0], m] = np.concatenate([g.real, g.imag]) * weights[k]
        sol = np.linalg.lstsq(np.vstack([a_ri, _tikhonov(a_ri)]), rhs, rcond=None)[0]
        for m, k in enumerate(ks):
            x[:, k // n, k % n] = sol[:, m] / col
    dr, dd = _to_residues(rational.poles, x, n)  # dd = 0 without perturb_d (no D column)
    return RationalModel(model.poles, model.residues + dr, model.dd + dd, model.ee,
                         model.kind, model.z0, delay=model.delay)
