"""Netlists, batched MNA, network poles, SPICE export/import, synthesis, ngspice runner.

Public names: :class:`Circuit`, :class:`Element`, :class:`Port` (``netlist``);
:class:`MnaSystem`, :class:`CircuitTransfer` (``mna``); :func:`network_poles` (``poles``);
:func:`to_spice` (``spice_export``); :func:`from_spice` (``spice_import``);
:func:`synthesize`, :func:`model_to_spice` (``synthesis``); :func:`transfer_on`,
:func:`pole_residue`, :class:`PoleResidue`, :class:`TransferMemo` (``transfer``: fast
pole-residue transfers over many frequencies). Every frequency solve of a network lives
in this package (``mna``, ``transfer`` and the solver family ``_solvers``, which holds the
pencil balancing and the tolerance policy). The ngspice runner lives in
:mod:`vfmodel.circuit.ngspice` (``run_ac``, ``run_tran``, ``run_raw``).
"""

from vfmodel.circuit.mna import CircuitTransfer, MnaSystem
from vfmodel.circuit.netlist import Circuit, Element, Port
from vfmodel.circuit.poles import network_poles
from vfmodel.circuit.spice_export import to_spice
from vfmodel.circuit.spice_import import from_spice
from vfmodel.circuit.synthesis import model_to_spice, synthesize
from vfmodel.circuit.transfer import PoleResidue, TransferMemo, pole_residue, transfer_on

__all__ = [
    "Circuit",
    "CircuitTransfer",
    "Element",
    "MnaSystem",
    "PoleResidue",
    "Port",
    "TransferMemo",
    "from_spice",
    "model_to_spice",
    "network_poles",
    "pole_residue",
    "synthesize",
    "to_spice",
    "transfer_on",
]
