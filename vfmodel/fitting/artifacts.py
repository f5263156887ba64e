"""Samples of a frequency response that are not data: export padding and isolated spikes.

- Padding: a run of trailing samples that repeat the last distinct sample bit for bit (some
  solvers export beyond their computed band by repeating the last value), after at least
  two varying samples (data equal from the first samples on is a constant response). No physical
  response is constant to the last digit over a band; a causal nearly lossless one cannot be
  constant at all, so fitting such a run only distorts the model.
- Spikes: single samples that leave a smooth response far above its local roughness while
  their neighbourhood is smooth without them (a glitch of the solver or the analyser). A
  rational fit chases such a sample with a pole narrower than the sample spacing, which the
  data cannot resolve, and the non-passive glitch then defeats passivity enforcement.

Spike test: every interior sample is predicted by the cubic through its two neighbours on
each side (Lagrange weights on the actual frequencies); the deviation is compared with a
robust local scale (1.4826 x the running median of the deviations of that entry, see
Gasser et al. 1986). A candidate must exceed ``spike_factor`` times that scale and
``floor`` times the RMS of the response, and once replaced by its prediction the deviations
of its neighbours must be ordinary (below ``isolation_factor`` times the scale): a sharp
resonance sampled at its peak leaves its skirts on the neighbours and is not flagged.

References
----------
T. Gasser, L. Sroka, C. Jennen-Steinmetz, "Residual variance and residual pattern in
nonlinear regression", Biometrika 73(3), 1986. doi:10.1093/biomet/73.3.625
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from vfmodel.core.frequency_data import FrequencyData

__all__ = ["DataArtifacts", "find_artifacts"]

_WINDOW = 21  # samples of the running median of the local scale


@dataclass(frozen=True)
class DataArtifacts:
    """Samples :func:`find_artifacts` found not to be data.

    Attributes
    ----------
    n_genuine : int
        Samples before the padding (``data.freq_hz[:n_genuine]`` is the computed band).
    padded_from_hz : float or None
        First padded frequency (None: no padding).
    spikes : tuple of int
        Indices (into the genuine samples) of isolated spikes.
    spike_freq_hz : tuple of float
        Their frequencies.
    """

    n_genuine: int
    padded_from_hz: float | None
    spikes: tuple[int, ...]
    spike_freq_hz: tuple[float, ...]

    @property
    def found(self) -> bool:
        return self.padded_from_hz is not None or bool(self.spikes)

    def describe(self) -> str:
        """One line for warnings and reports."""
        parts = []
        if self.padded_from_hz is not None:
            parts.append(
                f"samples from {self.padded_from_hz:.6g} Hz repeat the previous sample "
                "exactly (export padding)"
            )
        if self.spikes:
            fs = ", ".join(f"{f:.6g}" for f in self.spike_freq_hz)
            parts.append(f"isolated single-sample spikes at {fs} Hz")
        return "; ".join(parts) if parts else "no artifacts"


def _padding_start(values: NDArray[np.complex128]) -> int:
    """Number of samples up to and including the last distinct one (>= 2 repeats)."""
    k = values.shape[0]
    last = values[-1]
    j = k - 1
    while j > 0 and np.array_equal(values[j - 1], last):
        j -= 1
    # a response repeated from (nearly) the first sample on is constant data (an ideal
    # short, a resistive tee), not padding: padding follows a computed, varying band
    if j < 2:
        return k
    return j + 1 if k - 1 - j >= 2 else k


def _cubic_weights(f: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lagrange weights (K-4, 4) predicting sample k from k-2, k-1, k+1, k+2."""
    x = np.stack([f[:-4], f[1:-3], f[3:-1], f[4:]], axis=1)  # (K-4, 4)
    x0 = f[2:-2]
    w = np.ones_like(x)
    for i in range(4):
        for j in range(4):
            if i != j:
                w[:, i] *= (x0 - x[:, j]) / (x[:, i] - x[:, j])
    return w


def _deviations(f: NDArray[np.float64], v: NDArray[np.complex128]) -> NDArray[np.float64]:
    """|v_k - cubic prediction| for interior samples k = 2..K-3: (K-4, M)."""
    w = _cubic_weights(f)
    pred = (
        w[:, 0, None] * v[:-4]
        + w[:, 1, None] * v[1:-3]
        + w[:, 2, None] * v[3:-1]
        + w[:, 3, None] * v[4:]
    )
    out: NDArray[np.float64] = np.abs(v[2:-2] - pred)
    return out


def _local_scale(dev: NDArray[np.float64], tiny: float) -> NDArray[np.float64]:
    """Robust local scale per sample and entry (running median, edge-padded)."""
    n = dev.shape[0]
    win = min(_WINDOW, n if n % 2 else n - 1)
    if win < 3:
        return np.full_like(dev, max(float(np.median(dev)) * 1.4826, tiny))
    padded = np.pad(dev, ((win // 2, win // 2), (0, 0)), mode="edge")
    med = np.median(sliding_window_view(padded, win, axis=0), axis=-1)
    out: NDArray[np.float64] = np.maximum(1.4826 * med, tiny)
    return out


def find_artifacts(
    data: FrequencyData,
    *,
    spike_factor: float = 100.0,
    isolation_factor: float = 10.0,
    floor: float = 1e-4,
) -> DataArtifacts:
    """Find export padding and isolated single-sample spikes in a frequency response.

    Parameters
    ----------
    data : FrequencyData
        The response (any kind and port count).
    spike_factor : float
        A spike deviates from the cubic through its neighbours by more than this many
        robust local scales.
    isolation_factor : float
        With the spike replaced by its prediction, its neighbours deviate by less than this
        many local scales.
    floor : float
        A spike deviates by more than this fraction of the RMS of the whole response.

    Returns
    -------
    DataArtifacts
        See the module docstring for the tests.
    """
    f = np.asarray(data.freq_hz, dtype=float)
    v = data.values.reshape(data.n_freq, -1)
    n_gen = _padding_start(v)
    padded = f[n_gen] if n_gen < f.size else None
    f, v = f[:n_gen], v[:n_gen]
    spikes: list[int] = []
    if f.size >= 9:
        rms = float(np.sqrt(np.mean(np.abs(v) ** 2)))
        tiny = 1e-12 * max(float(np.max(np.abs(v))), 1e-300)
        dev = _deviations(f, v)
        scale = _local_scale(dev, tiny)
        ratio = np.max(dev / scale, axis=1)
        big = np.max(dev, axis=1) > floor * rms
        for i in (int(x) for x in np.flatnonzero((ratio > spike_factor) & big)):
            k = i + 2  # sample index
            if ratio[i] < np.max(ratio[max(i - 2, 0) : i + 3]):
                continue  # a neighbour deviates more: not the spike itself
            lo, hi = max(k - 5, 0), min(k + 6, f.size)
            vv = v[lo:hi].copy()
            w = _cubic_weights(f[k - 2 : k + 3])[0]
            vv[k - lo] = w[0] * v[k - 2] + w[1] * v[k - 1] + w[2] * v[k + 1] + w[3] * v[k + 2]
            dev2 = _deviations(f[lo:hi], vv)  # sample lo + 2 + j
            idx = [k - 1 - lo - 2, k + 1 - lo - 2]
            idx = [j for j in idx if 0 <= j < dev2.shape[0]]
            if np.all(dev2[idx] < isolation_factor * scale[[j + lo for j in idx]]):
                spikes.append(k)
    return DataArtifacts(
        n_genuine=int(n_gen),
        padded_from_hz=None if padded is None else float(padded),
        spikes=tuple(spikes),
        spike_freq_hz=tuple(float(f[k]) for k in spikes),
    )
