"""Black-box poles versus network poles: what the data support that the network lacks.

The black-box rational fit of a spectrum (vector fitting at the noise floor) holds the
poles the data support. Each black-box pole inside the measured band is matched to the
nearest network pole in the log-polar distance ``|ln|p/q|| + |arg p - arg q|``; a pole
with no network pole within ``tol`` is *unmatched*. Unmatched real poles (or a cluster of
them) where the network has none point at distributed physics (a relaxation, a
``sqrt(f)`` skin-effect behaviour, approximated by a few real poles); an unmatched
complex pair points at a missing resonance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["PoleComparison", "compare_poles"]

ArrC = NDArray[np.complex128]


@dataclass(frozen=True)
class PoleComparison:
    """Result of :func:`compare_poles` (poles in rad/s, upper half plane and real only)."""

    blackbox: ArrC
    network: ArrC
    matched: tuple[tuple[complex, complex], ...]
    unmatched_blackbox: ArrC
    band_hz: tuple[float, float]

    def summary(self) -> dict[str, object]:
        """JSON-ready summary (frequencies in Hz)."""
        def hz(p: complex) -> list[float]:
            return [float(p.real / (2 * np.pi)), float(p.imag / (2 * np.pi))]

        um = self.unmatched_blackbox
        return {
            "band_hz": list(self.band_hz),
            "n_blackbox_in_band": int(self.blackbox.size),
            "n_network_in_band": int(self.network.size),
            "n_matched": len(self.matched),
            "unmatched_blackbox_hz": [hz(p) for p in um],
            "unmatched_real": int(np.sum(np.abs(um.imag) == 0)),
            "unmatched_complex": int(np.sum(np.abs(um.imag) > 0)),
        }


def _in_band(p: ArrC, lo: float, hi: float) -> ArrC:
    p = np.asarray(p, dtype=complex)
    p = p[p.imag >= 0]
    f = np.abs(p) / (2 * np.pi)
    return p[(f >= lo) & (f <= hi)]


def compare_poles(blackbox: ArrC, network: ArrC, band_hz: tuple[float, float], *,
                  tol: float = 0.35) -> PoleComparison:
    """Match black-box poles to network poles inside ``band_hz`` (see the module)."""
    b = _in_band(blackbox, *band_hz)
    n = _in_band(network, *band_hz)
    matched: list[tuple[complex, complex]] = []
    unmatched: list[complex] = []
    used = np.zeros(n.size, bool)
    for p in b[np.argsort(np.abs(b))]:
        if n.size:
            d = np.abs(np.log(np.abs(n) / abs(p))) + np.abs(np.angle(n) - np.angle(p))
            d = np.where(used, np.inf, d)
            j = int(np.argmin(d))
            if d[j] <= tol:
                used[j] = True
                matched.append((complex(p), complex(n[j])))
                continue
        unmatched.append(complex(p))
    return PoleComparison(b, n, tuple(matched), np.array(unmatched, dtype=complex),
                          (float(band_hz[0]), float(band_hz[1])))
