"""Near-lossless reflections that turn the wrong way: data no causal passive model follows.

The per-frequency passivity floor (:mod:`vfmodel.fitting.data_passivity`) looks at each
frequency alone. A lossless one-port obeys more: its reactance rises with frequency
(Foster's reactance theorem), so ``S = (jX - z0) / (jX + z0)`` turns clockwise on the
Smith chart, its phase falls. A reflection of magnitude near 1 whose phase rises over most
of the band is therefore not the response of a causal passive port; a common cause is a
calibration whose reference plane lies beyond the device (andypfau/sparameterviewer's
measured SMA short: |S11| >= 0.998, the phase rises over 93 % of the band). A passive
model then has to leave the data, whatever its order, and enforcement ends far beyond the
data floor (9.3x for that short).

Reference: R. M. Foster, "A reactance theorem", Bell System Technical Journal 3(2), 1924,
doi:10.1002/j.1538-7305.1924.tb01358.x.
"""

from __future__ import annotations

import numpy as np

from vfmodel.core.frequency_data import FrequencyData

__all__ = ["backward_reflections"]

NEAR_LOSSLESS = 0.95  # |S_ii| from which a reflection is treated as lossless
_WINDOW = 0.05  # phase change taken over this fraction of the samples (noise)
_RISING = 0.5  # share of the windows with rising phase that flags the port


def backward_reflections(data: FrequencyData) -> list[tuple[int, float]]:
    """Ports (0-based) of square S data whose reflection stays above
    :data:`NEAR_LOSSLESS` in magnitude and whose phase rises over more than half of the
    windows of 5 % of the samples (module docstring), with that share; [] otherwise."""
    if data.kind != "S" or data.n_out != data.n_in or data.n_freq < 20:
        return []
    k = max(2, int(data.n_freq * _WINDOW))
    out = []
    for i in range(data.n_out):
        h = data.values[:, i, i]
        mag = np.abs(h)
        near = (mag[k:] >= NEAR_LOSSLESS) & (mag[:-k] >= NEAR_LOSSLESS)
        if np.mean(near) < 0.5:
            continue
        ph = np.unwrap(np.angle(h))
        share = float(np.mean((ph[k:] - ph[:-k])[near] > 0))
        if share > _RISING:
            out.append((i, share))
    return out
