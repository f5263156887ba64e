"""Analytic motor-like impedance for the vector-fitting tests (not made with the fitter).

A three-section RLC ladder seen from the terminals of a winding to frame: the winding
inductance and resistance in series sections, winding-to-frame capacitance with loss in
the shunt sections, and a lossy inter-turn capacitance across the first section. Over
1 kHz-10 MHz |Z| falls from about 100 kohm (capacitive) through several series and
parallel resonances down to about 10 ohm, and rises again (inductive) at the top.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FREQ_LO_HZ = 1e3
FREQ_HI_HZ = 1e7


def _par(a: NDArray[np.complex128], b: NDArray[np.complex128]) -> NDArray[np.complex128]:
    out: NDArray[np.complex128] = a * b / (a + b)
    return out


def motor_like_impedance(freq_hz: NDArray[np.float64]) -> NDArray[np.complex128]:
    """Input impedance (ohm) of the ladder at ``freq_hz`` (analytic, complex)."""
    s = 2j * np.pi * np.asarray(freq_hz, dtype=float)

    def series(r: float, l_h: float) -> NDArray[np.complex128]:
        return r + s * l_h

    def shunt(r: float, c_f: float) -> NDArray[np.complex128]:
        out: NDArray[np.complex128] = r + 1.0 / (s * c_f)
        return out

    # innermost section: winding end to frame
    z = shunt(20.0, 0.6e-9)
    z = series(4.0, 60e-6) + z
    z = _par(shunt(8.0, 0.5e-9), z)
    z = series(2.0, 250e-6) + z
    z = _par(shunt(5.0, 0.4e-9), z)
    first = series(1.0, 1.5e-3) + z
    # inter-turn capacitance with loss across the first series section
    z = _par(first, shunt(30.0, 0.15e-9) + series(0.0, 2e-6))
    # lead inductance and resistance of the connection
    z = series(0.5, 0.3e-6) + z
    return np.asarray(z, dtype=complex)
