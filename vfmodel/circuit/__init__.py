"""Netlists, batched MNA, network poles, SPICE export/import, synthesis, ngspice runner.

Public names: :class:`Circuit`, :class:`Element`, :class:`Port` (``netlist``);
:class:`MnaSystem`, :class:`CircuitTransfer` (``mna``); :func:`network_poles` (``poles``);
:func:`to_spice` (``spice_export``); :func:`from_spice` (``spice_import``);
:func:`synthesize`, :func:`model_to_spice` (``synthesis``); the ngspice runner lives in
:mod:`vfmodel.circuit.ngspice` (``run_ac``, ``run_tran``, ``run_raw``).
"""

from vfmodel.circuit.mna import CircuitTransfer, MnaSystem
from vfmodel.circuit.netlist import Circuit, Element, Port
from vfmodel.circuit.poles import network_poles
from vfmodel.circuit.spice_export import to_spice
from vfmodel.circuit.spice_import import from_spice
from vfmodel.circuit.synthesis import model_to_spice, synthesize

__all__ = [
    "Circuit",
    "CircuitTransfer",
    "Element",
    "MnaSystem",
    "Port",
    "from_spice",
    "model_to_spice",
    "network_poles",
    "synthesize",
    "to_spice",
]
