"""Input handling of :func:`vfmodel.fitting.vectfit.vector_fit`: data conversion and
checks, weights, excluded samples, out-of-band anchors and pole bounds of S fits, the
order limit and the common delay."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from vfmodel._choices import Kind, Weighting, check_choice
from vfmodel.core.frequency_data import FrequencyData, as_frequency_data
from vfmodel.errors import InputError

_SRC = "vector_fit"


# ---------------------------------------------------------------------- input handling
def _as_frequency_data(data: Any, kind: Kind | None) -> FrequencyData:
    if kind is not None:
        check_choice("kind", kind, Kind)
    return as_frequency_data(data, kind, source=_SRC)


_ALIASES = {"inverse": "inv_abs", "inverse-sqrt": "inv_sqrt_abs"}
_DECADE_SPAN = 10.0  # "auto": relative weighting when ||H(f)|| spans more than this factor


def _resolve_weighting(fd: FrequencyData, weighting: str) -> str:
    """Name of the weighting "auto" stands for (see :data:`vfmodel._choices.Weighting`)."""
    if weighting != "auto":
        return _ALIASES.get(weighting, weighting)
    if fd.kind == "S":
        return "uniform"
    norm = np.linalg.norm(fd.values.reshape(fd.n_freq, -1), axis=1)
    top = float(np.max(norm))
    low = float(np.min(norm))
    return "relative" if low <= 0 or top / low > _DECADE_SPAN else "uniform"


def _weights(fd: FrequencyData, weighting: Any) -> tuple[NDArray[np.float64], str]:
    """Weights (K, Mw) and the name of the weighting."""
    h = fd.values.reshape(fd.n_freq, -1)
    if isinstance(weighting, str):
        check_choice("weighting", weighting, Weighting)
        weighting = _resolve_weighting(fd, weighting)
        if weighting == "uniform":
            return np.ones((fd.n_freq, 1)), weighting
        if weighting == "relative":
            norm = np.linalg.norm(h, axis=1)
            norm = np.maximum(norm, 1e-12 * float(np.max(norm)))
            return (1.0 / np.where(norm > 0, norm, 1.0))[:, None], weighting
        mag = np.abs(h)
        floor = 1e-12 * max(float(np.max(mag)), 1e-300)
        mag = np.maximum(mag, floor)
        w = 1.0 / mag if weighting == "inv_abs" else 1.0 / np.sqrt(mag)
        return w, weighting
    w = np.asarray(weighting, dtype=float)
    if w.shape == (fd.n_freq,):
        w = w[:, None]
    elif w.shape == (1, fd.n_out, fd.n_in):  # per response, every frequency
        w = np.repeat(w.reshape(1, -1), fd.n_freq, axis=0)
    elif w.shape == fd.values.shape:
        w = w.reshape(fd.n_freq, -1)
    else:
        raise InputError(
            "weighting array has the wrong shape",
            source=_SRC,
            place="weighting",
            found=str(w.shape),
            expected=f"{(fd.n_freq,)}, {(1, fd.n_out, fd.n_in)} or {fd.values.shape}",
        )
    if not np.all(np.isfinite(w)) or np.any(w < 0) or not np.any(w > 0):
        raise InputError(
            "weights must be finite, non-negative and not all zero",
            source=_SRC,
            place="weighting",
        )
    return w, "user"


def _exclude(w: NDArray[np.float64], exclude: Any, n_freq: int) -> NDArray[np.float64]:
    idx = np.asarray(exclude)
    if idx.size == 0:
        return w
    if idx.ndim != 1 or not np.issubdtype(idx.dtype, np.integer) or np.any(
        (idx < 0) | (idx >= n_freq)
    ):
        raise InputError(
            "exclude must be sample indices",
            source=_SRC,
            place="exclude",
            found=repr(exclude)[:80],
            expected=f"integers in [0, {n_freq})",
        )
    w = w.copy()
    w[idx] = 0.0
    if np.unique(idx).size > n_freq - 3:
        raise InputError("exclude leaves fewer than 3 samples", source=_SRC, place="exclude")
    return w


def _check_data(fd: FrequencyData) -> bool:
    """Reject data no rational fit can represent; True for frequency-independent data
    (fitted by D alone, without poles)."""
    src = fd.source or _SRC
    if fd.n_freq < 3:
        raise InputError(
            "too few frequency points for a rational fit",
            source=src,
            found=f"{fd.n_freq} point(s)",
            expected="at least 3 frequency points",
        )
    if fd.freq_hz[-1] <= 0:
        raise InputError("no positive frequency", source=src)
    h = fd.values.reshape(fd.n_freq, -1)
    scale = float(np.max(np.abs(h)))
    if scale == 0.0:  # zero everywhere (Z of a short, Y of an open): D = 0
        return True
    spread = float(np.max(np.abs(h - h.mean(axis=0, keepdims=True))))
    if spread > _CONSTANT * scale:
        return False
    if float(np.max(np.abs(h.mean(axis=0).imag))) > _CONSTANT * scale:
        raise InputError(
            "the data is a constant that is not real; no real rational model has a "
            "frequency-independent complex response",
            source=src,
            expected="a real constant or a frequency-dependent response",
        )
    return True


_CONSTANT = 1e-9  # relative spread over frequency below which the data is a constant


# S models: real poles within [f_lo / 100, 100 f_hi]. The lower bound was f_lo / 10 until
# session 33: Xyce's 5-port and 3-port S files (41 points, 10 Hz-100 kHz) need a pole near
# 0.5 Hz (scikit-rf's) and fitted 3.1e-6 / 2.5e-6 with it clamped at 1 Hz, 1.7e-9 / 1.9e-9
# with f_lo / 100; a Murata bead 5.8e-8 -> 7.6e-16 (scikit-rf 9e-15). Over the 68 files of
# vfbench, scikit-rf's and session 31's unseen set no file crossed 1.1x scikit-rf's error
# either way (ro,1.s1p 6.9e-3 -> 9.3e-3 with 5 poles instead of 9, scikit-rf 9.8e-3)
_POLE_SPAN = (100.0, 100.0)


_RIDGE = 1e-7  # S fits: Tikhonov weight of the residue solve (see _vf_core.Problem)


_ANCHOR_BELOW = (0.5, 0.2, 0.05, 0.0)  # anchor frequencies / lowest data frequency
_ANCHOR_ABOVE = (2.0, 5.0, 20.0, 100.0)  # anchor frequencies / highest data frequency
_ANCHOR_WEIGHT = 1e-4  # anchor weight relative to the median data weight


def _anchors(
    fd: FrequencyData,
    h: NDArray[np.complex128],
    w: NDArray[np.float64],
    omega_scale: float,
    rel_weight: float | None,
) -> tuple[NDArray[np.complex128], NDArray[np.complex128], float] | None:
    """Out-of-band anchors of S fits (see :class:`_vf_core.Problem`): below the band
    (down to 0 Hz unless the data has it) the lowest sample, above it the highest."""
    if w.shape[1] != 1 or rel_weight == 0:
        return None
    pos = fd.omega[fd.omega > 0] / omega_scale
    below = [] if fd.freq_hz[0] == 0.0 else [pos[0] * x for x in _ANCHOR_BELOW]
    above = [x for x in _ANCHOR_ABOVE]
    s_v = 1j * np.array(below + above)
    lo, hi = h[int(np.argmax(fd.omega > 0))], h[-1]
    h_v = np.array([lo.real if x == 0 else lo for x in below] + [hi] * len(above))
    rel = _ANCHOR_WEIGHT if rel_weight is None else float(rel_weight)
    wp = w[w > 0]
    # equal weights (the default of S data): their median without the sort
    weight = rel * float(wp[0] if wp.min() == wp.max() else np.median(wp))
    return np.asarray(s_v, dtype=complex), np.asarray(h_v, dtype=complex), weight


def _pole_bounds(fd: FrequencyData, omega_scale: float) -> tuple[float, float] | None:
    """Real-pole bounds of S fits (see :class:`_vf_core.Problem`); None for immittances
    and transfer functions, whose poles near 0 Hz are physical (a capacitor)."""
    if fd.kind != "S":
        return None
    lo = float(fd.omega[fd.omega > 0][0]) / omega_scale
    return lo / _POLE_SPAN[0], _POLE_SPAN[1]


def _max_order(n_freq: int, has_dc: bool, n_extra: int) -> int:
    # real equations per response: 2 per sample, 1 at 0 Hz; unknowns: N + n_extra (+1 for
    # the sigma constant). Keep at least one more equation than unknowns.
    n_eq = 2 * n_freq - int(has_dc)
    return max(n_eq - n_extra - 2, 0)


def _delay(fd: FrequencyData, delay: Any) -> float:
    """The common delay of ``vector_fit(delay=...)`` in seconds (0: none)."""
    if isinstance(delay, str):
        if delay not in ("auto", "none"):
            raise InputError("delay must be 'auto', 'none' or seconds", found=repr(delay))
        if delay == "none" or fd.kind in ("Z", "Y") or _phase_turns(fd) <= _DELAY_TURNS:
            return 0.0
        h = fd.values.reshape(fd.n_freq, -1)
        energy = np.sum(np.abs(h) ** 2, axis=0)
        j = int(np.argmax(energy))
        if fd.n_out == fd.n_in > 1:
            # the delay is the transmissions': the largest off-diagonal entry unless it is
            # negligible (a filter's stopband leaves the reflections the larger entries; a
            # 16,001-point filter-and-line file gave a reflection's 0.16 ns for a 1.48 ns line)
            off = np.flatnonzero(~np.eye(fd.n_out, dtype=bool).ravel())
            k = int(off[np.argmax(energy[off])])
            if energy[k] >= 1e-2 * energy[j]:
                j = k
        ph = np.unwrap(np.angle(h[:, j]))
        # least-squares group delay of that entry
        return max(-float(np.polyfit(fd.omega, ph, 1)[0]), 0.0)
    tau = float(delay)
    if not (np.isfinite(tau) and tau >= 0):
        raise InputError("delay must be finite and >= 0 seconds", found=repr(delay))
    if tau > 0 and fd.kind in ("Z", "Y"):
        raise InputError(
            "a delay is supported for S and H data only",
            source=fd.source or _SRC,
            found=f"{fd.kind} data",
            expected="delay='none' or --kind S",
        )
    return tau


_DELAY_PAYS = 1.25  # delay="auto" keeps the delay when its error is within this factor
_DELAY_EXACT = 1e-6  # ... of the plain fit's error, its noise floor and this level
_DELAY_TURNS = 5.0  # phase turns over the band that point at a delay


def _phase_turns(fd: FrequencyData) -> float:
    """Largest number of phase turns over the band among the entries carrying at least
    1 % of the energy: a long delay shows as many turns."""
    h = fd.values.reshape(fd.n_freq, -1)
    energy = np.sum(np.abs(h) ** 2, axis=0)
    ph = np.unwrap(np.angle(h[:, energy >= 1e-2 * energy.max()]), axis=0)
    return float(np.max(np.abs(ph[-1] - ph[0]) / (2 * np.pi), initial=0.0))


