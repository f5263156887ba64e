"""Data and model abstractions of the detective.

A :class:`Channel` is one measured complex response (an impedance spectrum of a port or a
measurement topology) with its noise level. A *family* (:class:`Family`) is a starting
network together with the candidate changes (:class:`Candidate`: an effect of the
vocabulary at one place of the network) it knows how to apply; it predicts the channels for
a set of applied candidates and parameter values. The detective (``diagnose``) only talks
to this protocol, so the same loop serves the PMSM grey-box model and a user's own netlist.

Residual layout (used everywhere): channel after channel, for each ``[Re, Im]`` of
``log(model / measured) / sigma`` at its points, i.e. the channel ``c`` with ``n_c`` points
occupies ``2 n_c`` consecutive entries (real parts first).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from vfmodel.greybox.params import ParamSet, ParamSpec

__all__ = ["Candidate", "Channel", "Family", "channel_slices", "log_residual",
           "split_channels"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]


@dataclass(frozen=True)
class Channel:
    """One measured response.

    Attributes
    ----------
    where : str
        Label used in ``diagnosis.json`` (``"impedance:U-Frame"``, ``"impedance:Zin"``).
    freq_hz : (n,) float
    measured : (n,) complex
    sigma : (n,) float
        Standard deviation of the noise of ``Re log H`` and of ``Im log H`` (relative
        magnitude noise and phase noise in rad) at each point.
    noise_method : str
        How ``sigma`` was estimated (see :mod:`vfmodel.detective.noise`).
    blackbox_poles : (p,) complex or None
        Poles (rad/s) of the black-box rational fit of the channel, when one was made.
    """

    where: str
    freq_hz: ArrF
    measured: ArrC
    sigma: ArrF
    noise_method: str = ""
    blackbox_poles: ArrC | None = None

    @property
    def n(self) -> int:
        return int(self.freq_hz.size)


@dataclass(frozen=True)
class Candidate:
    """An effect of the vocabulary applied at one place of the network.

    ``params`` are the specifications of the parameters the change adds (with bounds);
    ``starts`` are a few start values (name -> value) for those parameters spread over the
    measured band, so the refit finds the relaxation or corner frequency wherever it is.
    """

    effect: str
    location: str
    params: tuple[ParamSpec, ...] = ()
    starts: tuple[tuple[tuple[str, float], ...], ...] = ()

    @property
    def key(self) -> tuple[str, str]:
        return (self.effect, self.location)

    @property
    def n_params(self) -> int:
        return len(self.params)


class Family(Protocol):
    """A starting network plus the candidate changes it can apply (see the module)."""

    @property
    def name(self) -> str: ...

    @property
    def channels(self) -> tuple[Channel, ...]: ...

    def start_params(self) -> ParamSet:
        """Parameters of the starting network (values = the start of the first fit)."""
        ...

    def free_names(self, applied: Sequence[Candidate], params: ParamSet) -> tuple[str, ...]:
        """Parameters fitted for the network with ``applied`` (including theirs)."""
        ...

    def candidates(self) -> tuple[Candidate, ...]:
        """Every change the starting network lacks, at every place it applies."""
        ...

    def predict(self, applied: Sequence[Candidate], params: ParamSet) -> list[ArrC]:
        """Model response of every channel (same order and grids as :attr:`channels`)."""
        ...

    def poles(self, applied: Sequence[Candidate], params: ParamSet) -> ArrC:
        """Natural frequencies (rad/s) of the network."""
        ...


def channel_slices(channels: Sequence[Channel]) -> list[slice]:
    """Slice of each channel in the residual vector (``2 n_c`` entries each)."""
    out, k = [], 0
    for c in channels:
        out.append(slice(k, k + 2 * c.n))
        k += 2 * c.n
    return out


def log_residual(channels: Sequence[Channel], predicted: Sequence[ArrC]) -> ArrF:
    """Noise-normalised residual ``log(model / measured) / sigma`` (module layout)."""
    parts = []
    for c, h in zip(channels, predicted, strict=True):
        lr = np.log(np.asarray(h) / c.measured) / c.sigma
        # wrap the phase difference into (-pi, pi]
        im = np.angle(np.exp(1j * lr.imag * c.sigma)) / c.sigma
        parts += [lr.real, im]
    return np.concatenate(parts) if parts else np.zeros(0)


def split_channels(r: ArrF, jm: ArrF | None, n_f: int, n_c: int, cols: Sequence[int],
                   n_names: int) -> tuple[list[ArrF], list[ArrF]]:
    """A term's residual in the layout ``[Re (f, c), Im (f, c)]`` (``n_f`` points, ``n_c``
    channels) split into one residual ``[Re, Im]`` per channel (the layout above), and its
    Jacobian ``jm`` (columns: the term's local names) into per-channel blocks over all
    ``n_names`` fitted names, the local ones at ``cols`` (``jm`` None: no blocks)."""
    rr = r.reshape(2, n_f, n_c)
    rs = [rr[:, :, c].ravel() for c in range(n_c)]
    if jm is None:
        return rs, []
    jj = jm.reshape(2, n_f, n_c, len(cols))
    js = []
    for c in range(n_c):
        full = np.zeros((2 * n_f, n_names))
        full[:, cols] = jj[:, :, c, :].reshape(2 * n_f, len(cols))
        js.append(full)
    return rs, js
