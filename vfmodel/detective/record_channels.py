"""The further recording channels ``u_B_DE`` and ``i_CM`` (CONTRACT section 2a) as channels
of the PMSM detective (:mod:`vfmodel.detective.pmsm`).

A recording may carry the drive-end bearing voltage ``u_B_DE`` (shaft end ``SD`` to frame)
and the common-mode current ``i_CM`` (the sum of the three phase currents into the machine
terminals). Each becomes, at the speed of its recording, three detective channels
``bearing_de:<rpm>rpm:<phase>`` and ``i_cm:<rpm>rpm:<phase>`` (the H1 transfer from the
terminal voltage of each phase, as ``bearing:<rpm>rpm:<phase>`` for ``u_B``), after the
shaft-to-frame spectra.

They are treated exactly as the bearing voltage is: the measured side is the H1 estimate
of the channel from the three terminal voltages of the same record, with the same filter,
resampling and estimator settings (:func:`vfmodel.greybox.objective.prepare_output`); the
model side is the network's transfer from the terminal sources to that quantity
(:data:`vfmodel.greybox.objective.RECORD_QUANTITIES`) applied to the measured terminal
spectra in periodic steady state and passed through the same estimator; the difference is
whitened per bin by the covariance of the channel's own H1 estimate; bins, band, bin step
and input-noise bias as for ``u_B`` (the term is made by the same function,
``vfmodel.detective.pmsm._bearing_term``, with the channel's output). The Jacobian is the
bearing term's adjoint one (:meth:`vfmodel.greybox.objective.BearingTerm.residual`, the
sensitivities of the channel's transfer). A term is compiled once per network structure;
the terms run in the family's evaluation pool beside the u_B records.

Measured (``diagnose DATASET --without <the case's list in cases.json>``, this code against
main 13331ee, on a 2-core machine shared with other runs): on ``data/concealed/
pmsm_two_layer_x``, ``pmsm_contact_x``, ``pmsm_null_bearing_x`` and a second draw
(``scripts/make_concealed.py --seed 11 --unseen``) of the two-layer and null cases the
channels add 1164-1242 residual entries to 2250-2328 and the findings are those of main
(the null cases gain nothing). Mean chi2 per entry of the new channels at the final fit
0.74-0.94 (single channels 0.37-2.1), as the u_B channels of the same records (0.90-1.13)
below 1 at speed; with the metallic contact concealed they carry 5.7 per entry (2.4-13.3)
before it is found. ``diagnose`` took 1.6-4x main's wall time.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vfmodel._choices import BearingState
from vfmodel.core.recording import BEARING_DE, COMMON_MODE_CURRENT, Recording
from vfmodel.detective.problem import Channel, split_channels
from vfmodel.detective.shaft_frame import local_names
from vfmodel.greybox.assembly import PHASES
from vfmodel.greybox.network import NetSpec
from vfmodel.greybox.objective import (
    RECORD_QUANTITIES,
    BearingTerm,
    PreparedRecording,
    RecordQuantity,
    prepare_output,
)
from vfmodel.greybox.params import ParamSet

__all__ = ["CHANNEL_PREFIX", "RecordChannelTerm", "record_terms", "term_channels",
           "term_residual"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]

CHANNEL_PREFIX = {BEARING_DE: "bearing_de", COMMON_MODE_CURRENT: "i_cm"}
"""Detective channel name of each further recording channel (``<prefix>:<rpm>rpm:<phase>``)."""

TermBuilder = Callable[[PreparedRecording, NetSpec, ParamSet, BearingState, RecordQuantity],
                       BearingTerm]
"""Makes the record term of a prepared record (the detective's ``_bearing_term``)."""


@dataclass(frozen=True, eq=False)
class RecordChannelTerm:
    """One further channel of one recording (module docstring). ``prep`` is the record
    prepared with that channel as its output."""

    channel: str
    prep: PreparedRecording
    build: TermBuilder = field(repr=False)
    _terms: dict[NetSpec, BearingTerm] = field(default_factory=dict, repr=False)

    @property
    def speed_rpm(self) -> float:
        return self.prep.speed_rpm

    @property
    def wheres(self) -> tuple[str, ...]:
        """Channel names, one per terminal phase."""
        return tuple(f"{CHANNEL_PREFIX[self.channel]}:{self.speed_rpm:g}rpm:{ph}"
                     for ph in PHASES)

    def term(self, family: Any, applied: Sequence[Any], params: ParamSet) -> BearingTerm:
        """The record term of the network ``applied`` (compiled once per structure; the
        element values come with each evaluation)."""
        spec = family.spec(applied)
        if spec not in self._terms:
            self._terms[spec] = self.build(self.prep, spec,
                                           family.at_speed(params, self.speed_rpm),
                                           family.state(self.speed_rpm, applied),
                                           RECORD_QUANTITIES[self.channel])
        return self._terms[spec]

    def channels(self, family: Any, params: ParamSet) -> list[Channel]:
        """The detective channels of the starting structure (:func:`term_channels`)."""
        return term_channels(self.term(family, (), params), self.wheres)

    def model(self, family: Any, applied: Sequence[Any], params: ParamSet) -> list[ArrC]:
        """The network's H1 per phase (the estimator applied to the modelled channel)."""
        h = self.term(family, applied, params).h1_model(family.at_speed(params,
                                                                        self.speed_rpm))
        return [h[:, i] for i in range(h.shape[1])]

    def residual(self, family: Any, applied: Sequence[Any], params: ParamSet,
                 names: Sequence[str] | None = None) -> tuple[list[ArrF], list[ArrF]]:
        """Whitened residual of each phase channel (``[Re, Im]`` of its bins) and, with
        ``names``, its derivative with respect to ``log`` of ``names`` (a per-speed copy
        acts at its speed only, a base lubricant value not while the rotor turns)."""
        return term_residual(family, self.term(family, applied, params), applied, params,
                             self.speed_rpm, names)


def term_channels(bt: BearingTerm, wheres: Sequence[str]) -> list[Channel]:
    """The detective channels of a record term, one per terminal phase (``wheres``): the
    measured H1 with the noise ``sqrt(2) sigma / |H1|`` of ``ln H1`` (u_B and the further
    channels alike)."""
    out = []
    for i, where in enumerate(wheres):
        hm = bt.h_meas[:, i]
        out.append(Channel(where, bt.freq_hz, hm, np.sqrt(2) * bt.sigma[:, i] / np.abs(hm),
                           "h1_covariance"))
    return out


def term_residual(family: Any, bt: BearingTerm, applied: Sequence[Any], params: ParamSet,
                  rpm: float, names: Sequence[str] | None = None
                  ) -> tuple[list[ArrF], list[ArrF]]:
    """Whitened residual of a record term at ``rpm`` per phase channel (``[Re, Im]`` of its
    bins) and, with ``names``, its derivative with respect to ``log`` of ``names`` (a
    per-speed copy acts at its speed only, a base lubricant value not while the rotor
    turns: :func:`vfmodel.detective.shaft_frame.local_names`)."""
    ps = family.at_speed(params, rpm)
    nn = tuple(names or ())
    loc, cols = local_names(nn, rpm, params)
    if names is not None and loc:
        r, jm = bt.residual(ps, loc, jac=True, lmap=family._lmap(applied, ps, loc))
        assert jm is not None
    else:
        r, jm = bt.residual(ps)[0], np.zeros((bt.n_residuals, 0))
    # term layout [Re (f, k), Im (f, k)] -> one channel per whitened component k
    return split_channels(r, jm if names is not None else None, bt.h_meas.shape[0], 3,
                          cols, len(nn))


def record_terms(recordings: Sequence[Recording], preps: Sequence[PreparedRecording],
                 build: TermBuilder) -> list[RecordChannelTerm]:
    """Terms of the further channels the recordings carry (by recording, in the order of
    ``preps``, which are the recordings prepared for ``u_B``; then ``u_B_DE`` before
    ``i_CM``); none when no recording carries one."""
    out = []
    for rec, prep in zip(recordings, preps, strict=True):
        for ch in rec.extra_channels:
            out.append(RecordChannelTerm(ch, prepare_output(prep, rec.channel(ch), ch,
                                                            source=rec.source), build))
    return out
