"""`Dataset`: impedance spectra by topology and recordings by speed (CONTRACT sections 2
and 2a), with the optional geometry and lubricant data of ``dataset.toml``."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.machine_info import BearingInfo, MachineInfo, PriorOverride
from vfmodel.core.recording import Recording


@dataclass(frozen=True)
class SpeedImpedance:
    """One ``[[impedance_at_speed]]`` entry: a 1-port Z spectrum of ``topology`` measured
    while the rotor turns at ``speed_rpm`` (> 0)."""

    topology: str
    speed_rpm: float
    data: FrequencyData


@dataclass(frozen=True)
class Dataset:
    """A measurement campaign of one machine.

    ``impedance`` maps the six paper topologies (``U-Frame`` ... ``W-U``, CONTRACT section 2)
    to 1-port Z spectra at standstill; code that iterates over the paper's spectra uses it.
    The further measurements of CONTRACT section 2a are kept apart so that such code sees
    nothing new: ``further_impedance`` (standstill spectra of
    :data:`vfmodel._choices.FURTHER_TOPOLOGIES`, e.g. ``Shaft-Frame``) and
    ``impedance_at_speed`` (spectra while the rotor turns, sorted by topology and speed).
    ``recordings`` are sorted by speed; each may carry ``u_B_DE`` and ``i_CM``.
    ``machine``, ``bearing`` and ``prior_overrides`` are the optional ``[machine]``,
    ``[bearing]`` and ``[priors]`` tables (see :mod:`vfmodel.core.machine_info`).
    """

    name: str
    impedance: dict[str, FrequencyData]
    recordings: tuple[Recording, ...] = ()
    description: str = ""
    temperature_c: float | None = None
    root: Path | None = field(default=None, compare=False)
    further_impedance: dict[str, FrequencyData] = field(default_factory=dict)
    impedance_at_speed: tuple[SpeedImpedance, ...] = ()
    machine: MachineInfo | None = None
    bearing: BearingInfo | None = None
    prior_overrides: dict[str, PriorOverride] = field(default_factory=dict)

    @property
    def speeds_rpm(self) -> tuple[float, ...]:
        return tuple(float(r.speed_rpm or 0.0) for r in self.recordings)

    @property
    def has_further_measurements(self) -> bool:
        """Whether any measurement of CONTRACT section 2a is present."""
        return bool(self.further_impedance or self.impedance_at_speed
                    or any(r.extra_channels for r in self.recordings))

    def impedance_at(self, topology: str, speed_rpm: float) -> FrequencyData:
        """The spectrum of ``topology`` at ``speed_rpm`` (0: the standstill spectrum)."""
        from vfmodel.errors import InputError

        if speed_rpm == 0:
            spectra = {**self.impedance, **self.further_impedance}
            if topology in spectra:
                return spectra[topology]
        for s in self.impedance_at_speed:
            if s.topology == topology and abs(s.speed_rpm - speed_rpm) < 1e-9:
                return s.data
        raise InputError(f"no {topology} impedance at {speed_rpm:g} rpm", source=self.name)

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
