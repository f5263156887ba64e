"""Further measurements (CONTRACT section 2a) of the project's virtual test bench
(``scripts/make_testbench.py --extra-measurements``), from the bench's own drive circuit.

``u_B_DE``: the drive-end shaft end ``SD`` to frame; ``i_CM``: the sum of the three phase
currents entering the machine terminals (the cable's series-inductor current less the
current of its terminal capacitance ``C_term``, KCL at each terminal); both through the
scope's probe response, as the paper's channels are (:func:`vfmodel.greybox.drive.
steady_state`). ``Shaft-Frame``: the impedance between ``SN`` and frame with the
terminals open.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vfmodel.circuit.mna import MnaSystem
from vfmodel.circuit.netlist import Circuit
from vfmodel.greybox.drive import (
    CableSpec,
    InverterSpec,
    ScopeSpec,
    drive_circuit,
    inverter_spectra,
    probe_response,
)
from vfmodel.signals.periodic import periodic_response

__all__ = ["EXTRA_OUTPUTS", "extra_steady_state", "extra_transfer", "shaft_frame_impedance"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]
INV = ("inv.U", "inv.V", "inv.W")
EXTRA_OUTPUTS = ("SD", "U", "V", "W", "i(cable.U.L)", "i(cable.V.L)", "i(cable.W.L)")


def extra_transfer(mna: MnaSystem, cable: CableSpec, freq_hz: ArrF) -> ArrC:
    """``(n_f, 2, 3)`` from the unit inverter sources to ``v(SD)`` and ``i_CM`` of the
    compiled drive circuit ``mna`` (:func:`~vfmodel.greybox.drive.drive_circuit`)."""
    h = mna.response(freq_hz, INV, EXTRA_OUTPUTS, method="modal")
    jw_c = 2j * np.pi * np.asarray(freq_hz)[:, None] * cable.c_f
    i_cm = h[:, 4:7, :].sum(axis=1) - jw_c * h[:, 1:4, :].sum(axis=1)
    return np.stack([h[:, 0, :], i_cm], axis=1)


def extra_steady_state(machine: Circuit, inv: InverterSpec, cable: CableSpec,
                       scope: ScopeSpec, speed_rpm: float, *,
                       mna: MnaSystem | None = None) -> ArrF:
    """Noise-free periodic steady state (2, n_samples): ``u_B_DE`` and ``i_CM`` after the
    probe, on the time grid of :func:`~vfmodel.greybox.drive.steady_state`."""
    x = inverter_spectra(inv, speed_rpm, scope)
    n = round(scope.n_periods * scope.fs_hz / inv.f_sw_hz)
    f = np.arange(x.shape[1]) * scope.fs_hz / n
    sys = drive_circuit(machine, cable).mna if mna is None else mna
    h = extra_transfer(sys, cable, f) * probe_response(f, scope.probe_bw_hz)[:, None, None]
    return periodic_response(h, x, n)


def shaft_frame_impedance(machine: Circuit, freq_hz: ArrF) -> ArrC:
    """Impedance ``SN``-frame of the machine network (terminals U, V, W open)."""
    pair = ("SN", machine.ground)
    return machine.mna.response(freq_hz, [pair], [pair])[:, 0, 0]
