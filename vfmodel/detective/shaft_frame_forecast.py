"""What a shaft-to-frame measurement would show (:mod:`vfmodel.detective.recommend`): the
network's shaft-to-frame impedance and its sensitivities, the spread a measurement would
show from the network's own uncertainty, the wide band (to :data:`WIDE_F_HI_HZ`) and the
nonlinear refit that says whether the network without an effect mimics it there
(:func:`mimicked_on`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vfmodel.detective.problem import Candidate
from vfmodel.detective.shaft_frame import local_names, speed_tag
from vfmodel.greybox.assembly import BEARING_NODE, default_params, lubricant_names
from vfmodel.greybox.objective import dlogv_dlogp
from vfmodel.greybox.params import ParamSet

__all__ = ["SHAFT_FRAME_MEAS", "WIDE", "WIDE_F_HI_HZ", "Net", "mimicked_on", "network_spread",
           "separation", "wide_grid"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]

_LUB_BASE = frozenset(lubricant_names(default_params()))
"""The bearing's speed-dependent names (their per-speed copies carry ``@<rpm>rpm``)."""

SHAFT_FRAME_MEAS = "impedance:Shaft-Frame"
WIDE = "impedance:Shaft-Frame:wide"
"""Internal key of the wide-band shaft-to-frame measurement (:data:`WIDE_F_HI_HZ`); it is
reported as ``impedance:Shaft-Frame`` with its ``band_hz``."""

WIDE_F_HI_HZ = 1e8
"""Upper end of the wide-band shaft-to-frame measurement: the band of an impedance
analyser such as Keysight's E4990A (to 120 MHz), above the corner ``1 / (2 pi R_h C)`` of
the Hertzian contact resistance (ohms) and the film capacitance (nF), 10-30 MHz, where an
edge capacitance, which bypasses ``R_h``, and the film part ways (module docstring)."""


def wide_grid(freq: ArrF) -> ArrF | None:
    """The wide-band grid: ``freq``'s lower end to :data:`WIDE_F_HI_HZ`, log-spaced at
    ``freq``'s density (points per decade); None when ``freq`` already reaches half of
    it."""
    lo, hi = float(freq[0]), float(freq[-1])
    if freq.size < 2 or hi >= 0.5 * WIDE_F_HI_HZ or lo <= 0:
        return None
    per = (freq.size - 1) / math.log10(hi / lo)
    n = round(per * math.log10(WIDE_F_HI_HZ / lo)) + 1
    return np.geomspace(lo, WIDE_F_HI_HZ, n)


@dataclass(frozen=True)
class Net:
    """A network: the candidates applied to the family's starting network, and values."""

    applied: tuple[Candidate, ...]
    params: ParamSet


def _shaft_frame(family: Any, fit: Net, rpm: float, freq: ArrF) -> ArrC:
    spec = family.spec(fit.applied)
    c = spec.build(family.at_speed(fit.params, rpm), family.state(rpm, fit.applied))
    pair = (BEARING_NODE, c.ground)
    return np.asarray(c.mna.response(freq, [pair], [pair])[:, 0, 0])


def _dlnz_dlnp(family: Any, fit: Net, names: Sequence[str], rpm: float, freq: ArrF
               ) -> ArrC:
    """``d ln Z_SF / d ln p`` (n_f, len(names)) of the shaft-to-frame impedance at ``rpm``
    (adjoint network sensitivities chained through the element values; a per-speed copy
    ``<name>@<s>rpm`` acts at ``s`` only, the base lubricant value not at all while it
    turns)."""
    spec = family.spec(fit.applied)
    state = family.state(rpm, fit.applied)
    ps = family.at_speed(fit.params, rpm)
    loc, cols = local_names(names, rpm, fit.params)
    out = np.zeros((freq.size, len(names)), dtype=complex)
    if not loc:
        return out
    c = spec.build(ps, state)
    v = np.asarray(c.param_values, dtype=float)
    dl = dlogv_dlogp(ps, loc, spec, state)
    used = np.flatnonzero(np.any(dl != 0, axis=1))
    pair = (BEARING_NODE, c.ground)
    z, dz = c.mna.response_and_jacobian(freq, [pair], [pair], v,
                                        params=[c.mna.param_names[e] for e in used],
                                        diagonal=True)
    g = ((dz[:, 0, :] * v[used]) @ dl[used]) / z[:, 0, 0][:, None]
    out[:, cols] = g
    return out


def network_spread(family: Any, fit: Net, names: Sequence[str], cov: ArrF, rpm: float,
                   freq: ArrF, sigma: float) -> float:
    """Expected chi-square of a shaft-to-frame measurement at ``rpm`` from the network's own
    uncertainty: ``sum_f g_f^T cov g_f / sigma^2`` over Re and Im of ``g = d ln Z / d ln p``
    with ``cov`` the covariance of ``ln p`` of ``names`` (data and prior); ``inf`` when an
    unbounded direction enters."""
    g = _dlnz_dlnp(family, fit, names, rpm, freq)
    total = 0.0
    finite = np.isfinite(np.diag(cov))
    for part in (g.real, g.imag):
        if np.any(np.abs(part[:, ~finite]) > 0):
            return math.inf
        q = part[:, finite]
        total += float(np.einsum("fi,ij,fj->", q, cov[np.ix_(finite, finite)], q))
    return total / sigma**2


def separation(d_log: ArrC, sigma: float) -> float:
    """``sum |d|^2 / sigma^2`` of differences ``d`` of ``ln Z`` (Re and Im each with
    standard deviation ``sigma``)."""
    return float(np.sum(np.abs(d_log) ** 2) / sigma**2)


UPPER_NFEV = 40
"""Evaluations of the refit of :func:`mimicked_on`."""


def mimicked_on(family: Any, a: Net, b: Net, rpm: float, freq: ArrF, sigma: float,
                hold: tuple[tuple[str, ...], ArrF] | None = None,
                standstill: bool = False) -> float:
    """Chi-square by which the network without the effect (``b``) misses the shaft-to-frame
    spectrum of the network with it (``a``) at ``rpm`` after a nonlinear least-squares
    refit (``scipy.optimize.least_squares``, bounded, analytic Jacobian
    :func:`_dlnz_dlnp`) of the values of ``b`` that act on that spectrum: the bearing's
    values of that speed (``<name>@<rpm>rpm``, at standstill the base lubricant values)
    free, the machine values held by ``hold`` = (names, ``J``): a move ``x`` of their
    ``ln p`` costs ``|J x|^2``, the linearised chi-square it causes on the present data
    (:func:`_present`, without priors; the detective refits by least squares), not
    counted in the result. Without ``hold`` the machine values are fixed. ``standstill``:
    the measurement is the pair of that spectrum and the standstill one on the same grid
    (both fitted, both counted).

    Why nonlinear: the bearing's values mimic a bearing-side effect through an exact
    reparametrisation on the spectra's band (an edge capacitance beside the film: an RC
    one-port either way, Foster form), far from linear for an effect of some size: an
    edge capacitance of 0.34 nF on ``pmsm_edge`` (seed 0) was missed on the spectra's
    band by Delta chi2 136 after the linearised refit (:func:`refit_moves`), while the
    detective, refitting nonlinearly, found nothing of the truth's 0.80 nF there (Delta
    chi2 -0.1 on ``pmsm_edge_x``). Why the machine values are held, not free: refitted to
    one spectrum alone, the path's inductances and resistances mimic even the edge's
    departure above the contact's corner."""
    from scipy.optimize import least_squares

    tag = speed_tag(rpm) if rpm > 0 else ""
    names = family.free_names(b.applied, b.params)
    g0 = _dlnz_dlnp(family, b, names, rpm, freq)
    acting = [n for k, n in enumerate(names) if np.any(g0[:, k] != 0)]
    hold_names, hold_j = hold if hold is not None else ((), np.zeros((0, 0)))
    bearing = [n for n in acting if (tag and n.endswith(tag)) or (not tag and n in _LUB_BASE)]
    machine = [n for n in acting if n not in bearing and n in hold_names]
    use = bearing + machine
    spectra = [rpm, 0.0] if standstill and rpm > 0 else [rpm]
    targets = [np.log(_shaft_frame(family, a, r, freq)) for r in spectra]
    cols = [hold_names.index(n) for n in machine]
    jm = hold_j[:, cols] if machine else np.zeros((0, 0))
    x0 = np.log([b.params[n] for n in use])
    specs = [b.params.spec(n) for n in use]
    lo = np.minimum(np.log([sp.lower for sp in specs]), x0)
    hi = np.maximum(np.log([sp.upper for sp in specs]), x0)
    nb = len(bearing)

    def net(x: ArrF) -> Net:
        return Net(b.applied, b.params.with_values(
            {n: math.exp(float(v)) for n, v in zip(use, x, strict=True)}, clip=True))

    def fun(x: ArrF) -> ArrF:
        parts = []
        for r, t in zip(spectra, targets, strict=True):
            d = (np.log(_shaft_frame(family, net(x), r, freq)) - t) / sigma
            parts += [d.real, d.imag]
        return np.concatenate([*parts, jm @ (x[nb:] - x0[nb:])])

    def jac(x: ArrF) -> ArrF:
        parts = []
        for r in spectra:
            g = _dlnz_dlnp(family, net(x), use, r, freq) / sigma
            parts += [g.real, g.imag]
        return np.vstack([*parts, np.hstack([np.zeros((jm.shape[0], nb)), jm])])

    n_meas = 2 * freq.size * len(spectra)
    if not use:
        return float(np.sum(fun(x0)[:n_meas] ** 2))
    res = least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf",
                        max_nfev=UPPER_NFEV)
    return float(np.sum(res.fun[:n_meas] ** 2))
