"""Physics library of the detective for user networks: each vocabulary effect as a
transformation of a netlist at one place (element, node pair or port).

=============================  ===========  ==============================================
effect                         place        transformation (new parameters)
=============================  ===========  ==============================================
``insulation_dielectric_loss``  capacitor C  Debye branch ``R_d + C_d`` across C with
``lubricant_dielectric_loss``                ``C_d = k_d C``, ``R_d = tau_d / C_d``
                                             (``k_d``, ``tau_d``)
``winding_skin_effect``,        resistor R   RL ladder (Fig. 14 of the reference paper)
``frame_skin_effect``,                       ``R_0 + (jwL_0 || (R_1 + (jwL_1 || R_2 ..)))``
``shaft_skin_effect``,                       with ``R_0 = R``, ``R_k = R rho^k``,
``ball_skin_effect``                         ``L_k = l_int / rho^k`` (``l_int``, ``rho``)
``lubricant_two_layer``         capacitor C  second layer ``R_2 || C_2`` in series with C
                                             (``R_2``, ``C_2``)
``hertzian_edge_capacitance``   nodes a:b    capacitor ``C_edge`` between a and b
``fixture_inductance``          port P       series ``jw L_fix`` added to the port's
                                             measured impedance (``L_fix``)
=============================  ===========  ==============================================

The residual signatures (what the detective sees when the effect is missing) are those of
:data:`vfmodel.greybox.effects.EFFECT_INFO`: a Debye branch makes the capacitance fall
with frequency and adds a loss peak (phase a few degrees above -90 degrees around
``1/(2 pi tau_d)``); a skin ladder makes the real part of the branch impedance grow like
``sqrt(f)`` above the first corner ``R_1 / (2 pi L_0)``; a fixture inductance adds an
inductive rise proportional to ``f`` at the top of the band, the same in every port.
Start values of the new parameters are spread over the measured band (relaxation time and
corner frequency at several decades), so each refit is a small multistart.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from vfmodel.circuit.netlist import Element
from vfmodel.detective.problem import Candidate
from vfmodel.errors import InputError
from vfmodel.greybox.params import ParamSpec
from vfmodel.greybox.substructures import rl_ladder

__all__ = ["TRANSFORMS", "Transform", "apply", "make_candidate"]

_N_RUNGS = 3


@dataclass(frozen=True)
class Transform:
    """How an effect changes a user network: ``place`` is ``capacitor``, ``resistor``,
    ``nodes`` or ``port``."""

    kind: str
    place: str


TRANSFORMS: dict[str, Transform] = {
    "insulation_dielectric_loss": Transform("debye", "capacitor"),
    "lubricant_dielectric_loss": Transform("debye", "capacitor"),
    "winding_skin_effect": Transform("skin", "resistor"),
    "frame_skin_effect": Transform("skin", "resistor"),
    "shaft_skin_effect": Transform("skin", "resistor"),
    "ball_skin_effect": Transform("skin", "resistor"),
    "lubricant_two_layer": Transform("layer", "capacitor"),
    "hertzian_edge_capacitance": Transform("shunt_c", "nodes"),
    "fixture_inductance": Transform("series_l", "port"),
}
"""Effects of the vocabulary a user network can be given (``metallic_contact`` needs the
bearing states of the PMSM model and is not offered)."""


def _starts(name: str, values: np.ndarray, extra: Mapping[str, float]) -> tuple[
        tuple[tuple[str, float], ...], ...]:
    return tuple(((name, float(v)), *extra.items()) for v in values)


def make_candidate(effect: str, location: str, base_value: float, band_hz: tuple[float, float],
                   z_scale: float = 1.0) -> Candidate:
    """Candidate ``effect`` at ``location`` with parameter bounds and starts.

    ``base_value``: value of the element at the place (C for capacitors, R for resistors;
    unused for nodes and ports); ``band_hz``: measured band; ``z_scale``: typical
    impedance magnitude at the top of the band (ports).
    """
    if effect not in TRANSFORMS:
        raise InputError("effect not available for user networks", place=effect,
                         expected=", ".join(sorted(TRANSFORMS)))
    t = TRANSFORMS[effect]
    lo, hi = band_hz
    w_lo, w_hi = 2 * np.pi * lo, 2 * np.pi * hi
    fk = np.logspace(np.log10(lo), np.log10(hi), 6)[1:-1]
    p = f"{location}.{effect}"
    if t.kind == "debye":
        tau_lo, tau_hi = 0.01 / w_hi, 100.0 / w_lo
        specs: tuple[ParamSpec, ...] = (
            ParamSpec(f"{p}.k_d", 0.05, 1e-4, 2.0, "effect", "", "C_d / C"),
            ParamSpec(f"{p}.tau_d", float(np.sqrt(tau_lo * tau_hi)), tau_lo, tau_hi,
                      "effect", "s", "relaxation time"))
        return Candidate(effect, location, specs,
                         _starts(f"{p}.tau_d", 1 / (2 * np.pi * fk), {f"{p}.k_d": 0.05}))
    if t.kind == "skin":
        r = base_value
        rho = 4.0
        # corner R_1/(2 pi L_0) = r rho / (2 pi l_int)
        l_lo, l_hi = r * rho / (100 * w_hi), r * rho / (0.01 * w_lo)
        specs = (ParamSpec(f"{p}.l_int", float(np.sqrt(l_lo * l_hi)), l_lo, l_hi, "effect",
                           "H", "internal inductance of the ladder"),
                 ParamSpec(f"{p}.rho", rho, 1.2, 100.0, "effect", "", "ladder ratio"))
        return Candidate(effect, location, specs,
                         _starts(f"{p}.l_int", r * rho / (2 * np.pi * fk), {f"{p}.rho": rho}))
    if t.kind == "layer":
        c = base_value
        r_lo, r_hi = 0.01 / (w_hi * 100 * c), 100.0 / (w_lo * 0.1 * c)
        specs = (ParamSpec(f"{p}.R_2", float(np.sqrt(r_lo * r_hi)), r_lo, r_hi, "effect",
                           "ohm", "second-layer resistance"),
                 ParamSpec(f"{p}.C_2", 10 * c, 0.1 * c, 1e3 * c, "effect", "F",
                           "second-layer capacitance"))
        return Candidate(effect, location, specs,
                         _starts(f"{p}.R_2", 1 / (2 * np.pi * fk * 10 * c), {f"{p}.C_2": 10 * c}))
    if t.kind == "shunt_c":
        c_lo, c_hi = 1e-3 / (w_hi * max(z_scale, 1e-12)), 1e3 / (w_lo * max(z_scale, 1e-12))
        c_lo, c_hi = max(c_lo, 1e-18), max(c_hi, 1e-15)
        specs = (ParamSpec(f"{p}.C", float(np.sqrt(c_lo * c_hi)), c_lo, c_hi, "effect", "F",
                           "edge capacitance"),)
        return Candidate(effect, location, specs,
                         _starts(f"{p}.C", np.geomspace(c_lo * 10, c_hi / 10, 4), {}))
    # series_l: port inductance; |jwL| from 1e-4 to 10 times the impedance at the top
    l_lo, l_hi = 1e-5 * z_scale / w_hi, 10 * z_scale / w_hi
    specs = (ParamSpec(f"{p}.L", float(np.sqrt(l_lo * l_hi)), l_lo, l_hi, "effect", "H",
                       "lead/fixture inductance"),)
    return Candidate(effect, location, specs,
                     _starts(f"{p}.L", np.geomspace(l_lo * 10, l_hi / 10, 4), {}))


def apply(elements: list[Element], cand: Candidate, values: Mapping[str, float]) -> list[Element]:
    """Elements after applying ``cand`` (not for ports: those act on the prediction)."""
    t = TRANSFORMS[cand.effect]
    p = f"{cand.location}.{cand.effect}"
    if t.kind == "shunt_c":
        a, b = cand.location.split(":")
        return [*elements, Element(f"{p}.C", "capacitor", (a, b), values[f"{p}.C"])]
    if t.kind == "series_l":
        return elements
    out: list[Element] = []
    for e in elements:
        if e.name != cand.location:
            out.append(e)
            continue
        a, b = e.nodes
        if t.kind == "debye":
            c_d = values[f"{p}.k_d"] * e.value
            out += [e, Element(f"{p}.R_d", "resistor", (a, f"{p}.d"), values[f"{p}.tau_d"] / c_d),
                    Element(f"{p}.C_d", "capacitor", (f"{p}.d", b), c_d)]
        elif t.kind == "skin":
            out += rl_ladder(p, a, b, r_dc=e.value, l_ext=0.0, l_int=values[f"{p}.l_int"],
                             rho=values[f"{p}.rho"], n_rungs=_N_RUNGS)
        else:  # layer: C in series with R_2 || C_2
            m = f"{p}.m"
            out += [Element(e.name, e.kind, (a, m), e.value),
                    Element(f"{p}.R_2", "resistor", (m, b), values[f"{p}.R_2"]),
                    Element(f"{p}.C_2", "capacitor", (m, b), values[f"{p}.C_2"])]
    return out
