"""`Recording`: uniformly sampled channels of one oscilloscope record.

The paper's four channels are ``u_U``, ``u_V``, ``u_W`` (terminal to frame) and ``u_B``
(NDE shaft end to frame); a record may carry the further channels of CONTRACT section 2a,
``u_B_DE`` (drive-end shaft end to frame, V) and ``i_CM`` (common-mode current, the sum of
the three phase currents at the machine terminals, A), after them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from vfmodel.errors import InputError

MIN_SAMPLES = 64
"""Shortest record accepted (the H1 estimator needs several segments of a few samples)."""

TERMINALS = ("u_U", "u_V", "u_W")
BEARING = "u_B"
BEARING_DE = "u_B_DE"
COMMON_MODE_CURRENT = "i_CM"
EXTRA_CHANNELS = (BEARING_DE, COMMON_MODE_CURRENT)
"""Further channels of CONTRACT section 2a, in their file order."""


@dataclass(frozen=True)
class Recording:
    """Channels ``data[c, k]`` sampled at ``fs``; ``data`` is (n_channels, n_samples).

    Parameters
    ----------
    fs : float
        Sample rate, samples per second.
    data : array (n_channels, n_samples)
    channels : tuple of str
        Channel names, e.g. ``("u_U", "u_V", "u_W", "u_B")``.
    speed_rpm : float, optional
    t0 : float
        Time of the first sample, seconds.
    source : str, optional
        File the record came from (for messages).
    """

    fs: float
    data: NDArray[np.float64]
    channels: tuple[str, ...]
    speed_rpm: float | None = None
    t0: float = 0.0
    source: str | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        src = self.source or "Recording"
        fs = float(self.fs)
        if not (np.isfinite(fs) and fs > 0):
            raise InputError("sample rate must be positive", source=src, found=str(self.fs))
        data = np.array(self.data, dtype=float)
        if data.ndim == 1:
            data = data[None, :]
        names = tuple(str(c) for c in self.channels)
        if data.ndim != 2 or data.shape[0] != len(names):
            raise InputError(
                "data must be (n_channels, n_samples) with one name per channel",
                source=src,
                found=f"shape {np.shape(self.data)} for {len(names)} names",
            )
        if len(set(names)) != len(names):
            raise InputError("duplicate channel names", source=src, found=str(names))
        if data.shape[1] < MIN_SAMPLES:
            raise InputError(
                "record too short",
                source=src,
                found=f"{data.shape[1]} samples",
                expected=f"at least {MIN_SAMPLES}",
            )
        finite = np.isfinite(data)
        if not finite.all():
            c = int(np.argmin(finite.all(axis=1)))
            k = int(np.argmin(finite[c]))
            raise InputError(
                "NaN or infinite sample",
                source=src,
                place=f"channel {names[c]}, sample {k}",
                expected="finite numbers",
            )
        data.setflags(write=False)
        object.__setattr__(self, "fs", fs)
        object.__setattr__(self, "data", data)
        object.__setattr__(self, "channels", names)
        object.__setattr__(self, "t0", float(self.t0))
        if self.speed_rpm is not None:
            object.__setattr__(self, "speed_rpm", float(self.speed_rpm))

    @property
    def n_samples(self) -> int:
        return int(self.data.shape[1])

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.fs

    @property
    def t(self) -> NDArray[np.float64]:
        """Sample times, seconds."""
        return self.t0 + np.arange(self.n_samples) / self.fs

    def channel(self, name: str) -> NDArray[np.float64]:
        """One channel by name (InputError naming the missing channel otherwise)."""
        try:
            return self.data[self.channels.index(name)]
        except ValueError:
            raise InputError(
                f"no channel {name!r}",
                source=self.source,
                found=", ".join(self.channels),
            ) from None

    @property
    def terminals(self) -> NDArray[np.float64]:
        """Terminal voltages u_U, u_V, u_W as (3, n_samples)."""
        return np.stack([self.channel(c) for c in TERMINALS])

    @property
    def bearing(self) -> NDArray[np.float64]:
        """Bearing voltage u_B."""
        return self.channel(BEARING)

    def has_channel(self, name: str) -> bool:
        """Whether the record holds channel ``name``."""
        return name in self.channels

    @property
    def extra_channels(self) -> tuple[str, ...]:
        """The further channels of CONTRACT section 2a this record holds (file order)."""
        return tuple(c for c in EXTRA_CHANNELS if c in self.channels)

    @property
    def bearing_de(self) -> NDArray[np.float64] | None:
        """Drive-end bearing voltage ``u_B_DE`` (V), or None when not recorded."""
        return self.channel(BEARING_DE) if BEARING_DE in self.channels else None

    @property
    def common_mode_current(self) -> NDArray[np.float64] | None:
        """Common-mode current ``i_CM`` (A), or None when not recorded."""
        return self.channel(COMMON_MODE_CURRENT) if COMMON_MODE_CURRENT in self.channels \
            else None
