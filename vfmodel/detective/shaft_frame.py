"""The shaft-to-frame impedance (CONTRACT section 2a) as a channel of the PMSM detective.

A dataset may hold the impedance between the NDE shaft end ``SN`` and the frame, terminals
open, at standstill (``[impedance] "Shaft-Frame"``) and while the rotor turns
(``[[impedance_at_speed]]``). The network predicts it directly: the port ``SN``-frame of
the grey-box network in the bearing state of that speed (metallic contact closed at
standstill when the network has it), with the lubricant values of that speed (its
per-speed copies ``<name>@<s>rpm``; a speed without a recording has none, so its spectrum
is not used). Residual: ``log(Z_model / Z_meas) / sigma`` (Re and Im, the layout of
:mod:`vfmodel.detective.problem`), ``sigma`` estimated from the spectrum like the six
spectra (:func:`vfmodel.detective.noise.spectrum_noise`). Jacobian: adjoint network
sensitivities chained through the element values (:meth:`PortTerm.residual`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vfmodel.circuit.mna import MnaSystem
from vfmodel.greybox.assembly import BEARING_NODE
from vfmodel.greybox.params import ParamSet

__all__ = ["SHAFT_FRAME", "PortTerm", "local_names", "speed_tag"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]

SHAFT_FRAME = "Shaft-Frame"


def speed_tag(rpm: float) -> str:
    """Suffix of the PMSM detective's per-speed parameter copies (``@100rpm``)."""
    return f"@{rpm:g}rpm"


def local_names(names: Sequence[str], rpm: float, params: ParamSet
                ) -> tuple[list[str], list[int]]:
    """Names of the network at ``rpm`` and their columns in ``names``: the base names, and
    at a rotating speed the copies ``<name>@<rpm>rpm`` (as ``<name>``); a base value whose
    copy at ``rpm`` exists in ``params`` is replaced by it there (``PmsmFamily.at_speed``)
    and does not act, fitted or not; copies of other speeds do not act."""
    tag = speed_tag(rpm)
    loc, cols = [], []
    for j, n in enumerate(names):
        if "@" not in n:
            if rpm > 0 and n + tag in params:
                continue
            loc.append(n)
            cols.append(j)
        elif rpm > 0 and n.endswith(tag):
            loc.append(n[: -len(tag)])
            cols.append(j)
    return loc, cols


@dataclass(frozen=True, eq=False)
class PortTerm:
    """One shaft-to-frame spectrum at ``speed_rpm`` (module docstring)."""

    where: str
    speed_rpm: float
    freq_hz: ArrF
    z_meas: ArrC
    sigma: float
    _mna: dict[Any, MnaSystem] = field(default_factory=dict, repr=False)

    def _system(self, family: Any, applied: Sequence[Any], params: ParamSet
                ) -> tuple[Any, str, ParamSet, MnaSystem]:
        spec = family.spec(applied)
        state = family.state(self.speed_rpm, applied)
        ps = family.at_speed(params, self.speed_rpm)
        key = (spec, state)
        if key not in self._mna:      # compiled once per structure and state
            self._mna[key] = spec.build(ps, state).mna
        return spec, state, ps, self._mna[key]

    def model(self, family: Any, applied: Sequence[Any], params: ParamSet) -> ArrC:
        spec, state, ps, mna = self._system(family, applied, params)
        pair = (BEARING_NODE, "0")
        return np.asarray(mna.response(self.freq_hz, [pair], [pair],
                                       spec.values(ps, state))[:, 0, 0])

    def residual(self, family: Any, applied: Sequence[Any], params: ParamSet,
                 names: Sequence[str] | None = None) -> tuple[ArrF, ArrF | None]:
        """``r`` (2 n_f,) and, with ``names``, ``dr/d ln p`` (2 n_f, len(names))."""
        spec, state, ps, mna = self._system(family, applied, params)
        pair = (BEARING_NODE, "0")
        v = spec.values(ps, state)
        nf = self.freq_hz.size
        loc, cols = local_names(names or (), self.speed_rpm, params)
        if names is None or not loc:
            z = np.asarray(mna.response(self.freq_hz, [pair], [pair], v)[:, 0, 0])
            jm = None if names is None else np.zeros((2 * nf, len(names)))
        else:
            dl = family._lmap(applied, ps, loc).at(ps)
            used = np.flatnonzero(np.any(dl != 0, axis=1))
            h, dz = mna.response_and_jacobian(self.freq_hz, [pair], [pair], v,
                                              params=[mna.param_names[e] for e in used],
                                              diagonal=True)
            z = h[:, 0, 0]
            g = ((dz[:, 0, :] * v[used]) @ dl[used]) / z[:, None] / self.sigma
            jm = np.zeros((2 * nf, len(names)))
            jm[:nf, cols] = g.real
            jm[nf:, cols] = g.imag
        lr = np.log(z / self.z_meas) / self.sigma
        im = np.angle(np.exp(1j * lr.imag * self.sigma)) / self.sigma
        return np.concatenate([lr.real, im]), jm
