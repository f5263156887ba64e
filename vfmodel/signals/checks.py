"""Validation of sampled recordings: shapes, NaN/inf, equal lengths, clipping, record length.

Every check names the channel it complains about. Errors (:class:`InputError`) are raised
for data that cannot be processed (NaN, unequal lengths, too few samples); suspicious but
usable data (flat tops at the rails = clipping) gives a :class:`SignalWarning`.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vfmodel.errors import InputError, SignalWarning

__all__ = [
    "as_channels",
    "channel_names",
    "check_finite",
    "check_fs",
    "check_length",
    "find_clipping",
    "warn_clipping",
]


def channel_names(prefix: str, n: int, names: Sequence[str] | None = None) -> list[str]:
    """``names`` if given (checked for length), else ``prefix[0]``, ``prefix[1]``, ..."""
    if names is None:
        return [f"{prefix}[{i}]" for i in range(n)]
    out = [str(s) for s in names]
    if len(out) != n:
        raise InputError(
            "wrong number of channel names",
            place=prefix,
            found=f"{len(out)} names for {n} channels",
        )
    return out


def check_fs(fs: Any) -> float:
    """A finite, positive sample rate as float."""
    try:
        val = float(fs)
    except (TypeError, ValueError):
        raise InputError("sample rate must be a number", place="fs", found=repr(fs)) from None
    if not np.isfinite(val) or val <= 0:
        raise InputError("sample rate must be finite and > 0", place="fs", found=repr(fs))
    return val


def as_channels(
    x: Any, place: str, names: Sequence[str] | None = None, *, dtype: Any = np.float64
) -> tuple[NDArray[Any], list[str]]:
    """Stack ``x`` (1-D array, 2-D (channel, sample) array, or a sequence of 1-D arrays)
    into a 2-D array, raising :class:`InputError` naming the channel on unequal lengths.

    Returns the array and the channel names.
    """
    if isinstance(x, np.ndarray) and x.ndim in (1, 2):
        arr = x[None, :] if x.ndim == 1 else x
        if not np.issubdtype(arr.dtype, np.number) or np.iscomplexobj(arr):
            raise InputError("channels must be real numbers", place=place, found=str(arr.dtype))
        nm = channel_names(place, arr.shape[0], names)
        return np.asarray(arr, dtype=dtype), nm
    if isinstance(x, np.ndarray):
        raise InputError(
            "expected a 1-D signal or a 2-D (channel, sample) array",
            place=place,
            found=f"shape {x.shape}",
        )
    try:
        chans = [np.asarray(c) for c in x]
    except TypeError:
        raise InputError(
            "expected an array of samples", place=place, found=type(x).__name__
        ) from None
    if not chans:
        raise InputError("no channels", place=place)
    nm = channel_names(place, len(chans), names)
    for c, name in zip(chans, nm, strict=True):
        if c.ndim != 1:
            raise InputError(
                "each channel must be 1-D", place=f"{place}: channel {name!r}",
                found=f"shape {c.shape}",
            )
    n0 = chans[0].size
    for c, name in zip(chans, nm, strict=True):
        if c.size != n0:
            raise InputError(
                "channels of different lengths",
                place=f"{place}: channel {name!r}",
                found=f"{c.size} samples",
                expected=f"{n0} samples like channel {nm[0]!r}",
            )
    return np.asarray(np.stack(chans), dtype=dtype), nm


def check_finite(x: NDArray[Any], names: Sequence[str], place: str) -> None:
    """Raise :class:`InputError` naming the first channel with NaN or infinity."""
    for row, name in zip(x, names, strict=True):
        bad = ~np.isfinite(row)
        if bad.any():
            idx = int(np.argmax(bad))
            raise InputError(
                "recording contains NaN or infinity",
                place=f"{place}: channel {name!r}",
                found=f"{int(bad.sum())} bad samples, first at index {idx} ({row[idx]!r})",
                expected="finite samples (remove or interpolate the gaps first)",
            )


def check_length(
    n_samples: int, needed: int, names: Sequence[str], place: str, what: str
) -> None:
    """Raise :class:`InputError` when a record has fewer than ``needed`` samples."""
    if n_samples < needed:
        raise InputError(
            "record too short",
            place=f"{place}: channel {names[0]!r}"
            + (" (and all others)" if len(names) > 1 else ""),
            found=f"{n_samples} samples",
            expected=f"at least {needed} samples for {what}",
        )


def _longest_run(mask: NDArray[np.bool_]) -> int:
    """Length of the longest run of True in a 1-D boolean array."""
    if not mask.any():
        return 0
    m = np.concatenate(([False], mask, [False])).astype(np.int8)
    d = np.diff(m)
    starts = np.flatnonzero(d == 1)
    ends = np.flatnonzero(d == -1)
    return int(np.max(ends - starts))


def find_clipping(
    x: NDArray[Any], names: Sequence[str], *, min_run: int = 5
) -> list[tuple[str, int, str, float]]:
    """Channels with flat tops at their extreme values: ``(name, run, "maximum"|"minimum", level)``.

    A channel is called clipped when it is noisy (the median absolute second difference is
    non-zero, i.e. the signal never stays exactly constant on its own) and yet it sits
    exactly at its maximum or minimum value for at least ``min_run`` consecutive samples:
    the signature of an oscilloscope input driven beyond its vertical range (rail). Noise-free
    synthetic signals (ideal trapezoids) are not flagged: their flat tops are their nature.
    """
    found: list[tuple[str, int, str, float]] = []
    for row, name in zip(x, names, strict=True):
        if row.size < max(3, min_run):
            continue
        lo, hi = float(np.min(row)), float(np.max(row))
        span = hi - lo
        if span <= 0:
            continue
        noise = float(np.median(np.abs(np.diff(row, 2))))
        if noise <= 1e-12 * span:
            continue  # piecewise-linear (noise-free) signal: plateaus are legitimate
        tol = 1e-12 * span
        for label, level in (("maximum", hi), ("minimum", lo)):
            run = _longest_run(np.abs(row - level) <= tol)
            if run >= min_run:
                found.append((name, run, label, level))
                break
    return found


def warn_clipping(found: Sequence[tuple[str, int, str, float]], place: str) -> None:
    """One :class:`SignalWarning` per clipped channel found by :func:`find_clipping`."""
    for name, run, label, level in found:
        warnings.warn(
            f"{place}: channel {name!r} looks clipped: {run} consecutive samples sit "
            f"exactly at its {label} {level:.6g} (flat top at the rail) while the rest "
            "of the signal is noisy; increase the oscilloscope's vertical range or "
            "exclude the clipped segments",
            SignalWarning,
            stacklevel=3,
        )
