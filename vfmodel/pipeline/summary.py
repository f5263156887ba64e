"""Summary of a dataset for ``vfmodel info`` (numbers only; the CLI formats them)."""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from vfmodel.core.dataset import Dataset
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.recording import Recording
from vfmodel.signals.filters import F_CUT_HZ
from vfmodel.signals.spectral import log_noise_sigma


def spectrum_noise_pct(data: FrequencyData) -> float:
    """Relative complex noise ``|dZ|/|Z|`` of a densely sampled spectrum, percent
    (``sqrt(2)`` times :func:`~vfmodel.signals.spectral.log_noise_sigma`); NaN for fewer
    than 5 points."""
    return float(100 * np.sqrt(2) * log_noise_sigma(data.values[:, 0, 0]))


def floor_snr_db(x: NDArray[np.float64], fs: float) -> float:
    """SNR of a channel from its PSD floor in the top fifth of the band (white noise).

    The noise power is the floor level times the bandwidth; the signal power is the rest.
    """
    nper = int(min(4096, x.size))
    f, p = signal.welch(x - np.mean(x), fs=fs, nperseg=nper)
    top = f >= 0.8 * f[-1]
    noise = float(np.median(p[top])) * fs / 2
    total = float(np.trapezoid(p, f))
    if noise <= 0 or total <= noise:
        return float("-inf") if noise > 0 else float("inf")
    return float(10 * np.log10((total - noise) / noise))


def coherence_snr_db(rec: Recording, f_max_hz: float = F_CUT_HZ) -> float:
    """SNR of the bearing voltage from the multiple coherence with the terminal voltages.

    With gamma^2 the multiple coherence, the part of the output PSD explained by the inputs
    is gamma^2 G_yy and the rest (1 - gamma^2) G_yy is noise; both are integrated up to
    ``f_max_hz``.
    """
    from vfmodel.signals.h1 import h1_analysis

    n = rec.n_samples
    nper = int(2 ** np.floor(np.log2(max(64, n // 16))))
    res = h1_analysis(rec.terminals, rec.bearing, rec.fs, nperseg=nper)
    f = res.freq_hz
    coh = res.coherence.reshape(f.size, -1)[:, 0]  # one output: (n_f,)
    gyy = res.gyy.reshape(f.size, -1)[:, 0]
    band = (f > 0) & (f <= f_max_hz)
    c = np.clip(coh[band], 0.0, 1.0)
    sig = float(np.sum(c * gyy[band]))
    noi = float(np.sum((1 - c) * gyy[band]))
    return float(10 * np.log10(sig / noi)) if noi > 0 else float("inf")


def _spectrum_summary(d: FrequencyData) -> dict[str, Any]:
    mag = np.abs(d.values[:, 0, 0])
    return {
        "n_points": d.n_freq,
        "f_min_hz": float(d.freq_hz[0]),
        "f_max_hz": float(d.freq_hz[-1]),
        "z_min_ohm": float(mag.min()),
        "z_max_ohm": float(mag.max()),
        "noise_pct": spectrum_noise_pct(d),
    }


def dataset_summary(ds: Dataset) -> dict[str, Any]:
    """Plain-dict summary: spectra ranges and noise, recordings' rates, durations, SNR;
    the further measurements of CONTRACT section 2a (standstill spectra of further
    topologies, spectra at speed, further channels) and the given ``[machine]``,
    ``[bearing]`` and ``[priors]`` entries."""
    imp = {topo: _spectrum_summary(d) for topo, d in ds.impedance.items()}
    further = {topo: _spectrum_summary(d) for topo, d in ds.further_impedance.items()}
    at_speed = [{"topology": s.topology, "speed_rpm": s.speed_rpm,
                 **_spectrum_summary(s.data)} for s in ds.impedance_at_speed]
    recs = []
    for r in ds.recordings:
        terms = [floor_snr_db(r.channel(c), r.fs) for c in ("u_U", "u_V", "u_W")]
        recs.append(
            {
                "speed_rpm": float(r.speed_rpm or 0.0),
                "file": r.source,
                "fs_hz": r.fs,
                "n_samples": r.n_samples,
                "duration_s": r.duration_s,
                "peak_u_B_v": float(np.max(np.abs(r.bearing))),
                "snr_u_B_db": coherence_snr_db(r),
                "snr_terminals_db": float(np.mean(terms)),
                "extra_channels": list(r.extra_channels),
                "peak_u_B_DE_v": None if r.bearing_de is None
                else float(np.max(np.abs(r.bearing_de))),
                "rms_i_CM_a": None if r.common_mode_current is None
                else float(np.sqrt(np.mean(r.common_mode_current**2))),
            }
        )
    return {
        "name": ds.name,
        "root": str(ds.root),
        "description": ds.description,
        "temperature_c": ds.temperature_c,
        "impedance": imp,
        "further_impedance": further,
        "impedance_at_speed": at_speed,
        "recordings": recs,
        "machine": _given(ds.machine),
        "bearing": _given(ds.bearing),
        "prior_overrides": {k: _given(v) for k, v in ds.prior_overrides.items()},
    }


def _given(info: object) -> dict[str, Any] | None:
    """The fields of a ``[machine]``/``[bearing]``/``[priors]`` entry that were given."""
    if info is None:
        return None
    return {k: v for k, v in asdict(info).items() if v is not None}  # type: ignore[call-overload]
