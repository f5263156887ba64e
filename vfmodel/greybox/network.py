"""Model-structure choice of the identified network: effects, ladder rungs, winding sections.

:class:`NetSpec` bundles the structural options of
:func:`vfmodel.greybox.assembly.build_network` (effect set, rungs per RL ladder, winding
sections per phase; ``n_sections = 2`` is the paper's model) so that the identification
can select the model order by the residual (:func:`vfmodel.greybox.identify.identify`)
and every term builds the same structure.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vfmodel._choices import BearingState
from vfmodel.circuit.netlist import Circuit
from vfmodel.errors import InputError
from vfmodel.greybox.assembly import build_network, network_values
from vfmodel.greybox.effects import PAPER_EFFECTS, check_effects
from vfmodel.greybox.params import ParamSet

__all__ = ["NetSpec", "build"]


@dataclass(frozen=True)
class NetSpec:
    """Structure of the model network: effect set, rungs per ladder, winding sections."""

    effects: frozenset[str] = PAPER_EFFECTS
    n_rungs: int = 3
    n_sections: int = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "effects", check_effects(self.effects))
        if self.n_sections < 2 or self.n_rungs < 1:
            raise InputError("n_sections must be >= 2 and n_rungs >= 1",
                             found=f"n_sections={self.n_sections}, n_rungs={self.n_rungs}")

    def build(self, params: ParamSet | Mapping[str, float], state: BearingState = "standstill",
              sources: bool = False) -> Circuit:
        return build(params, self.effects, state, n_rungs=self.n_rungs,
                     n_sections=self.n_sections, sources=sources)

    def values(self, params: ParamSet | Mapping[str, float],
               state: BearingState = "standstill") -> NDArray[np.float64]:
        """Element values of :meth:`build` (``param_values`` order) without building the
        netlist (:func:`vfmodel.greybox.assembly.network_values`)."""
        return network_values(params, self.effects, state, n_rungs=self.n_rungs,
                              n_sections=self.n_sections)

    def to_json_dict(self) -> dict[str, object]:
        return {"effects": sorted(self.effects), "n_rungs": self.n_rungs,
                "n_sections": self.n_sections}


def build(params: ParamSet | Mapping[str, float], effects: Iterable[str] = PAPER_EFFECTS,
          state: BearingState = "standstill", *, n_rungs: int = 3, n_sections: int = 2,
          sources: bool = False) -> Circuit:
    """The grey-box network with ``n_sections`` winding sections per phase
    (:func:`vfmodel.greybox.assembly.build_network`)."""
    return build_network(params, check_effects(effects), state, n_rungs=n_rungs,
                         n_sections=n_sections, sources=sources)
