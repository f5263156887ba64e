"""scikit-rf's vector fitting as the reference of the benchmarks and tests: the response
of a fitted ``skrf.vectorFitting.VectorFitting`` on any frequencies, in vfmodel's layout,
and its order counted as vfmodel counts it."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray


def skrf_response(vf: Any, freq_hz: ArrayLike) -> NDArray[np.complex128]:
    """``(n_freq, n_ports, n_ports)`` response of the fitted ``vf`` at ``freq_hz``."""
    f = np.asarray(freq_hz, dtype=float)
    n = int(vf.network.nports)
    out = np.stack([[vf.get_model_response(i, j, f) for j in range(n)] for i in range(n)])
    return np.asarray(out.transpose(2, 0, 1), dtype=np.complex128)


def skrf_order(vf: Any) -> int:
    """Order of the fitted ``vf`` counted as vfmodel counts it: every pole (a complex pair
    is two)."""
    poles = np.asarray(vf.poles)
    return int(np.sum(poles.imag == 0) + 2 * np.sum(poles.imag != 0))


def skrf_auto_fit_error(path: str, values: ArrayLike, freq_hz: ArrayLike) -> float:
    """Relative RMS error ``||H_skrf - H||_F / ||H||_F`` of scikit-rf's ``auto_fit`` of
    the Touchstone file ``path`` against ``values`` (n_freq, n, n) at ``freq_hz``."""
    import skrf

    vf = skrf.vectorFitting.VectorFitting(skrf.Network(str(path)))
    vf.auto_fit()
    h = np.asarray(values)
    return float(np.linalg.norm(skrf_response(vf, freq_hz) - h) / np.linalg.norm(h))
