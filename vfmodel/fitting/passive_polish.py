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
from vfmodel.fitting._enforce import _entry_systems, _response, _tikhonov, _to_residues

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
    h0 = 1.0 if model.kind == "S" else float(np.sqrt(np.mean(np.abs(target) ** 2))) or 1.0
    col, systems, weights = _entry_systems(rational, f, target, weighting, perturb_d, h0)
    gap = target - _response(rational, f)  # what the change should add, per entry
    x = np.zeros((col.size, n, n))
    for k, (a_ri, w) in enumerate(zip(systems, weights, strict=True)):
        i, j = divmod(k, n)
        y = np.concatenate([gap[:, i, j].real, gap[:, i, j].imag]) * w
        lhs = np.vstack([a_ri, _tikhonov(a_ri)])
        rhs = np.concatenate([y, np.zeros(col.size)])
        x[:, i, j] = np.linalg.lstsq(lhs, rhs, rcond=None)[0] / col
    dr, dd = _to_residues(rational.poles, x, n)
    if not perturb_d:
        dd = np.zeros_like(dd)
    return RationalModel(model.poles, model.residues + dr, model.dd + dd, model.ee,
                         model.kind, model.z0, delay=model.delay)
