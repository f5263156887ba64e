"""Sampled signals: FFT filter, spectral energy and edges, MIMO H1 estimator, periodic and
transient response of an LTI model to sampled inputs.

Owns the 10 MHz analysis band (:data:`F_CUT_HZ`), the spectrum noise kernel
(:func:`log_noise_sigma`) and the periodic steady state (:func:`periodic_response`, used by
:func:`simulate_periodic` and by every network response of :mod:`vfmodel.greybox`).
Knows nothing of bearings or networks (bearing quantities such as ``BVR(f)`` live in
:mod:`vfmodel.greybox.bearing`).

Public names are imported lazily (PEP 562) so that importing one module of the package
does not load the others; ``__all__`` is the curated API. A function named like its module
(``identify``, ``simulate``, ``reproduce``, ...) is imported from that module.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vfmodel._lazy import lazy_exports

if TYPE_CHECKING:
    from vfmodel.signals.filters import (
        F_CUT_HZ,
        brickwall_filter,
        filter_blocks,
        lowpass_fir,
    )
    from vfmodel.signals.h1 import (
        H1Result,
        h1_analysis,
        h1_analysis_blocks,
        h1_estimate,
    )
    from vfmodel.signals.periodic import (
        periodic_response,
        resample_periodic,
    )
    from vfmodel.signals.simulate import (
        discrete_transfer,
        simulate_blocks,
        simulate_periodic,
    )
    from vfmodel.signals.spectral import (
        EdgeTimes,
        SpectralEnergy,
        cutoff_frequency,
        edge_times,
        energy_fraction_above,
        log_noise_sigma,
        spectral_energy,
    )

_EXPORTS: dict[str, str] = {
    "F_CUT_HZ": "filters",
    "brickwall_filter": "filters",
    "filter_blocks": "filters",
    "lowpass_fir": "filters",
    "EdgeTimes": "spectral",
    "SpectralEnergy": "spectral",
    "cutoff_frequency": "spectral",
    "edge_times": "spectral",
    "energy_fraction_above": "spectral",
    "spectral_energy": "spectral",
    "log_noise_sigma": "spectral",
    "H1Result": "h1",
    "h1_analysis": "h1",
    "h1_analysis_blocks": "h1",
    "h1_estimate": "h1",
    "discrete_transfer": "simulate",
    "simulate_blocks": "simulate",
    "simulate_periodic": "simulate",
    "periodic_response": "periodic",
    "resample_periodic": "periodic",
}

__all__ = [
    "F_CUT_HZ",
    "EdgeTimes",
    "H1Result",
    "SpectralEnergy",
    "brickwall_filter",
    "cutoff_frequency",
    "discrete_transfer",
    "edge_times",
    "energy_fraction_above",
    "filter_blocks",
    "h1_analysis",
    "h1_analysis_blocks",
    "h1_estimate",
    "log_noise_sigma",
    "lowpass_fir",
    "periodic_response",
    "resample_periodic",
    "simulate_blocks",
    "simulate_periodic",
    "spectral_energy",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)
