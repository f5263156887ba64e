"""vfmodel: vector-fitted, passivity-certified macromodels and grey-box bearing-voltage
models of inverter-fed electrical machines.

The public names are imported lazily so that ``import vfmodel`` (and the CLI) stays fast;
heavy dependencies (cvxpy, scikit-rf, matplotlib) load on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

_EXPORTS: dict[str, str] = {
    # core
    "FrequencyData": "vfmodel.core.frequency_data",
    "RationalModel": "vfmodel.core.rational_model",
    "StateSpace": "vfmodel.core.rational_model",
    "Recording": "vfmodel.core.recording",
    "Dataset": "vfmodel.core.dataset",
    "read_spectrum": "vfmodel.core.io_spectrum",
    "write_spectrum": "vfmodel.core.io_spectrum",
    "read_recording": "vfmodel.core.io_recording",
    "write_recording": "vfmodel.core.io_recording",
    "read_dataset": "vfmodel.core.io_dataset",
    # fitting
    "vector_fit": "vfmodel.fitting.vectfit",
    "FitReport": "vfmodel.fitting.vectfit",
    "check_passivity": "vfmodel.fitting.passivity",
    "enforce_passivity": "vfmodel.fitting.passivity",
    "PassivityReport": "vfmodel.fitting.passivity",
    # signals
    "h1_estimate": "vfmodel.signals.h1",
    "h1_analysis": "vfmodel.signals.h1",
    "bvr": "vfmodel.greybox.bearing",
    "brickwall_filter": "vfmodel.signals.filters",
    "simulate": "vfmodel.signals.simulate",
    "simulate_periodic": "vfmodel.signals.simulate",
    # circuit
    "Circuit": "vfmodel.circuit.netlist",
}

__all__ = sorted([*_EXPORTS, "__version__"])


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'vfmodel' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return __all__
