"""Joint refit over all speeds: shared rotor-side capacitances, per-speed lubricant.

After the stage-wise identification (machine from the spectra and the standstill record,
then the lubricant speed by speed with the machine fixed) the rotor-side capacitances are
known only through the standstill data, where the closed metallic contact shorts the
rotor: the spectra see the sum of the winding capacitances to frame (``C_wf``) and rotor
(``C_wr``), and the standstill bearing voltage is the rotor current (``~C_wr dv/dt``) times
the impedance of its path through the balls and the shaft, so it fixes only their product.
Every rotating record separates them: the divider ratio ``C_wr / (C_wr + C_rf + 2 C_b)``
sets the plateau after an edge, while at the ringing frequencies the ball inductance
blocks the film and the ratio tends to ``C_wr / (C_wr + C_rf)``. A lubricant fitted with a
wrong ``C_wr`` therefore matches the plateau and misses the ringing peak (independent
bench 104: ``C_wr`` 2.3x its truth, rotating peaks 18-28 % high). This stage refits them
together: ``C_wr``, ``C_rf``, the three ``C_wf`` and the rotor-current path (ball and shaft
resistance and inductances) shared by every record, with the impedance spectra and the
standstill transfer in the objective (so the total winding capacitance stays where the
spectra put it), and one copy of the lubricant parameters per rotating speed
(``<name>@<rpm>``). Measured on bench 104: ``C_wr`` 1580 -> 587 pF (truth 693 pF at high
frequency), rotating peak errors 28/25/18/19/18 % -> 5.7/2.6/2.9/5.6/5.2 %, impedance
MAPE 1.62 -> 1.68 %; with the capacitances alone (no path) 19/14/11/8/6 %.

The covariance of the joint fit gives each speed's lubricant its uncertainty including
that of the shared capacitances (:func:`speed_report`).

Opt-in (``identify(joint=True)``) since 2026-11-24: with the shaft and ball inductances
bounded physically and up to 6 winding sections, the stage-wise identification fits these
benches without it, and where it was kept its intervals covered the truth less often
(:func:`vfmodel.greybox.identify.identify`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vfmodel.greybox.network import NetSpec
from vfmodel.greybox.params import ParamSet, ParamSpec

__all__ = ["SHARED", "SpeedCopy", "extend", "speed_params", "tag"]

ArrF = NDArray[np.float64]

SHARED = ("insulation.C_wr", "airgap.C_rf", "winding.U.C_wf", "winding.V.C_wf",
          "winding.W.C_wf", "ball.R_dc", "ball.L_ext", "ball.L_int", "shaft.L_1", "shaft.L_2",
          "shaft.R_dc")
"""Parameters shared by every record in the joint stage: the rotor-side capacitances and
the path of the rotor current to the frame (balls, shaft)."""


def tag(speed_rpm: float) -> str:
    return f"@{speed_rpm:g}"


def extend(params: ParamSet, local: Sequence[str],
           speeds: dict[float, ParamSet]) -> ParamSet:
    """``params`` plus a copy ``<name>@<rpm>`` of each ``local`` name per speed (valued
    from that speed's parameter set)."""
    specs = list(params.specs)
    vals = list(params.values)
    for s, ps in speeds.items():
        for n in local:
            sp = params.spec(n)
            specs.append(ParamSpec(n + tag(s), sp.nominal, sp.lower, sp.upper,
                                   sp.group + tag(s), sp.unit, sp.description))
            vals.append(ps[n])
    return ParamSet(tuple(specs), tuple(vals))


def speed_params(ext: ParamSet, base_names: Sequence[str], speed_rpm: float,
                 local: Sequence[str]) -> ParamSet:
    """The plain parameter set of one speed from the extended set."""
    t = tag(speed_rpm)
    vals = {n: ext[n] for n in base_names}
    vals.update({n: ext[n + t] for n in local})
    specs = tuple(ext.spec(n) for n in base_names)
    return ParamSet(specs, tuple(vals[n] for n in base_names))


@dataclass(frozen=True)
class SpeedCopy:
    """A residual term of one speed seen through the extended parameter set.

    ``inner`` is any term with ``residual(params, names, jac)`` on the plain set; ``speed``
    None: a term that depends only on the shared (and fixed) parameters.
    """

    inner: object
    base_names: tuple[str, ...]
    local: tuple[str, ...]
    speed: float | None
    jac_method: str | None = None
    """Passed to the inner term's ``residual(method=...)`` (e.g. ``"adjoint"``: the H1
    term's forward differences cost one full transfer per shared parameter)."""

    @property
    def spec(self) -> NetSpec:
        return self.inner.spec  # type: ignore[attr-defined]

    @property
    def n_residuals(self) -> int:
        return int(self.inner.n_residuals)  # type: ignore[attr-defined]

    def _plain(self, ext: ParamSet) -> ParamSet:
        if self.speed is None:
            return ParamSet(tuple(ext.spec(n) for n in self.base_names),
                            tuple(ext[n] for n in self.base_names))
        return speed_params(ext, self.base_names, self.speed, self.local)

    def _map(self, names: Sequence[str]) -> list[tuple[int, str]]:
        """(column, inner name) of the extended ``names`` this term depends on."""
        t = tag(self.speed) if self.speed is not None else None
        out = []
        for j, n in enumerate(names):
            if "@" not in n:
                out.append((j, n))
            elif t is not None and n.endswith(t):
                out.append((j, n[: -len(t)]))
        return out

    def residual(self, params: ParamSet, names: Sequence[str] = (), jac: bool = False,
                 lmap: object = None) -> tuple[ArrF, ArrF | None]:
        p = self._plain(params)
        if not jac:
            r, _ = self.inner.residual(p)  # type: ignore[attr-defined]
            return r, None
        cols = self._map(names)
        inner_names = [n for _, n in cols]
        kw = {} if self.jac_method is None else {"method": self.jac_method}
        r, j = self.inner.residual(p, inner_names, jac=True, **kw)  # type: ignore[attr-defined]
        out = np.zeros((r.size, len(names)))
        for k, (col, _) in enumerate(cols):
            out[:, col] = j[:, k]
        return r, out

    def correlation_factor(self, params: ParamSet) -> float:
        cf = getattr(self.inner, "correlation_factor", None)
        return float(cf(self._plain(params))) if callable(cf) else 1.0
