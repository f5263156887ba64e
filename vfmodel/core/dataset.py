"""`Dataset`: impedance spectra by topology and recordings by speed (CONTRACT section 2)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.recording import Recording


@dataclass(frozen=True)
class Dataset:
    """A measurement campaign of one machine.

    ``impedance`` maps topology names (``U-Frame`` ... ``W-U``) to 1-port Z spectra;
    ``recordings`` are sorted by speed.
    """

    name: str
    impedance: dict[str, FrequencyData]
    recordings: tuple[Recording, ...] = ()
    description: str = ""
    temperature_c: float | None = None
    root: Path | None = field(default=None, compare=False)

    @property
    def speeds_rpm(self) -> tuple[float, ...]:
        return tuple(float(r.speed_rpm or 0.0) for r in self.recordings)

    def recording_at(self, speed_rpm: float) -> Recording:
        """The recording taken at ``speed_rpm``."""
        for r in self.recordings:
            if r.speed_rpm is not None and abs(r.speed_rpm - speed_rpm) < 1e-9:
                return r
        from vfmodel.errors import InputError

        raise InputError(
            f"no recording at {speed_rpm:g} rpm",
            source=self.name,
            found=", ".join(f"{s:g}" for s in self.speeds_rpm),
        )
