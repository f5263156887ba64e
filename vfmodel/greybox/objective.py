"""Residual vectors and Jacobians of the grey-box identification (conditions 1 and 2).

Parameters are varied as ``x = log(value)``. Element values of the network are functions of
the parameters (:func:`vfmodel.greybox.assembly.element_values`); their log-derivatives
``d log v_e / d log p_j`` are taken by central differences of that (cheap, solve-free)
mapping. The derivative of a response then follows by the chain rule:

    dH/dx_j = sum_e (dH/dv_e) v_e (d log v_e / d log p_j).

Condition 1 (impedance spectra, standstill): ``r = log(Z_model / Z_meas) / sigma`` split
into real part (log-magnitude ratio) and imaginary part (phase difference, rad);
``dH/dv_e`` by the adjoint method of the MNA system (exact).

Condition 2 (bearing transfer, paper eq. 21): ``H1_meas`` is the H1 estimate of the
filtered record (terminals -> u_B); ``H1_model`` the same estimator applied to the model
output computed from the same filtered terminal voltages in periodic steady state (the
network transfer on every FFT bin of the record, ``Y = sum_i H_i X_i``, inverse FFT), so a
record that does not start from rest and film time constants longer than the record are
handled. ``r = (H1_model - H1_meas) / sigma`` with ``sigma^2 = h_std^2 + (eps |H1_meas|)^2``
(H1 uncertainty plus a relative model-error floor). Its Jacobian is by forward differences
in ``x`` (each costs one pole-residue evaluation of the network, :mod:`vfmodel.circuit.transfer`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Literal

import numpy as np
import scipy.fft as sfft
from numpy.typing import NDArray

from vfmodel._choices import BearingState, check_choice
from vfmodel.circuit.lowrank import LowRankTransfer, low_rank_transfer
from vfmodel.circuit.mna import MnaSystem
from vfmodel.circuit.transfer import TransferMemo, transfer_on
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.recording import Recording
from vfmodel.errors import InputError
from vfmodel.greybox._h1op import H1Operator, h1_operator
from vfmodel.greybox.assembly import BEARING_NODE, SOURCES, TOPOLOGY_PORTS
from vfmodel.greybox.bearing import BEARING_C_REF_HZ
from vfmodel.greybox.input_noise import input_noise_psd
from vfmodel.greybox.network import NetSpec
from vfmodel.greybox.params import ParamSet
from vfmodel.signals.filters import F_CUT_HZ, brickwall_filter
from vfmodel.signals.h1 import H1Result, h1_analysis
from vfmodel.signals.periodic import periodic_response, resample_periodic
from vfmodel.signals.spectral import log_noise_sigma

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]

H1Weighting = Literal["diagonal", "covariance"]
"""Weighting of the condition-2 residual (:func:`bearing_term`)."""

_LOG_STEP = 1e-6       # central-difference step of d log v / d log p
_FD_STEP = 1e-4        # forward-difference step (log) of the condition-2 Jacobian
_FD_MAX = 12
_J_DENSE_HZ = 50e3     # adjoint grid of the record Jacobians: every record bin up to here
_J_LOG_POINTS = 300    # ... then this many log-spaced points
_J_TOP = 1.5           # condition 2: up to this multiple of the highest tested bin

RecordQuantity = tuple[tuple[str, float], ...]
"""The quantity a record term compares: a weighted sum ``sum_k w_k y_k`` of network outputs
(node voltages to ground, ``"i(<element>)"`` branch currents) of the network driven by the
terminal sources. ``((BEARING_NODE, 1.0),)`` is the paper's bearing voltage ``u_B``."""

BEARING_QUANTITY: RecordQuantity = ((BEARING_NODE, 1.0),)

RECORD_QUANTITIES: dict[str, RecordQuantity] = {
    "u_B": BEARING_QUANTITY,
    "u_B_DE": (("SD", 1.0),),
    # the sources' branch currents flow from the terminal through the source to the frame
    # (MNA convention): the current into the machine is their negative (measured: the sum
    # is -j 3.2e-4 A/V at 10 kHz on the paper's network, a capacitive current into it)
    "i_CM": tuple((f"i({src})", -1.0) for src in SOURCES),
}
"""The network quantity of each recording channel (CONTRACT sections 2 and 2a): ``u_B``
(NDE shaft end ``SN`` to frame), ``u_B_DE`` (drive-end shaft end ``SD`` to frame) and
``i_CM`` (the sum of the three phase currents into the machine terminals)."""


def quantity_vector(mna: MnaSystem, quantity: RecordQuantity) -> ArrF:
    """``Cout`` (N, 1) of ``quantity``: the weighted sum of the probes' output columns."""
    c = mna.output_matrix([name for name, _ in quantity])
    return np.asarray(c @ np.array([w for _, w in quantity], dtype=float)[:, None])


def values_of(params: ParamSet, spec: NetSpec, state: BearingState,
              sources: bool = False) -> ArrF:
    """Element values (in circuit parameter order) of the network for ``params``.

    The terminal sources are not parameters (same values with and without them). The
    netlist is not rebuilt: the terms hold a network compiled once and only its element
    values change (:meth:`NetSpec.values`)."""
    del sources
    return spec.values(params, state)


def dlogv_dlogp(params: ParamSet, names: Sequence[str], spec: NetSpec,
                state: BearingState, sources: bool = False) -> ArrF:
    """``d log v_e / d log p_j`` (n_elements, n_names) by differences of step 1e-6."""
    v0 = np.log(values_of(params, spec, state, sources))
    cols = []
    for n in names:
        x0 = params[n]
        step = _LOG_STEP if x0 * np.exp(_LOG_STEP) <= params.spec(n).upper else -_LOG_STEP
        p1 = params.with_values({n: x0 * np.exp(step)}, clip=True)
        cols.append((np.log(values_of(p1, spec, state, sources)) - v0) / step)
    return np.stack(cols, axis=1) if cols else np.zeros((v0.size, 0))


def _chain(dv: ArrC, v: ArrF, dl: ArrF) -> ArrC:
    """``d h / d log p = sum_e (d h / d v_e) v_e (d log v_e / d log p)``: (..., n_e) with
    (n_e,) and (n_e, n_p) -> (..., n_p), as one matrix product (a three-operand einsum
    runs an unblocked loop, 12x slower on the record Jacobians)."""
    if v.size == 0:              # no element moves (e.g. only the fixture inductance)
        return np.zeros((*dv.shape[:-1], dl.shape[1]), dtype=complex)
    lead = dv.shape[:-1]
    return np.asarray(((dv * v).reshape(-1, v.size) @ dl).reshape(*lead, dl.shape[1]),
                      dtype=complex)


def _used_elements(dl: ArrF) -> NDArray[np.intp]:
    """Elements whose value depends on at least one fitted parameter (rows of ``dl`` that
    are not zero): the only columns of the network Jacobian a term needs."""
    return np.flatnonzero(np.any(dl != 0, axis=1))


@dataclass(frozen=True)
class LogMap:
    """``d log v / d log p`` of a network structure for the parameters ``names``.

    The element values are products of powers of the parameters except for a few sums
    (e.g. ``L_ext = (1 - l_frac) L``); the columns that are constant are computed once
    (forward differences at the start and at a second point detect the others), the
    non-constant ones are recomputed at every call of :meth:`at`.
    """

    spec: NetSpec
    names: tuple[str, ...]
    const: ArrF                       # (n_elements, n_names)
    varying: tuple[int, ...]

    def at(self, params: ParamSet) -> ArrF:
        if not self.varying:
            return self.const
        out = self.const.copy()
        sub = [self.names[j] for j in self.varying]
        out[:, list(self.varying)] = dlogv_dlogp(params, sub, self.spec, "standstill")
        return out


def log_map(params: ParamSet, names: Sequence[str], spec: NetSpec) -> LogMap:
    """:class:`LogMap` of ``spec`` for ``names`` (element order of every state/sources)."""
    names = tuple(names)
    a0 = dlogv_dlogp(params, names, spec, "standstill")
    lo, hi = params.log_bounds(names)
    x1 = np.clip(params.to_log(names) + 0.3, lo, hi)
    a1 = dlogv_dlogp(params.from_log(x1, names), names, spec, "standstill")
    varying = tuple(int(j) for j in np.flatnonzero(np.max(np.abs(a1 - a0), axis=0) > 1e-5))
    return LogMap(spec, names, a0, varying)


# ----------------------------------------------------------------------------- condition 1
@dataclass(frozen=True)
class ImpedanceTerm:
    """Condition 1: the measured spectra of the topologies and the compiled network."""

    topologies: tuple[str, ...]
    freq_hz: ArrF
    z_meas: ArrC          # (n_f, n_t)
    sigma: ArrF           # (n_t,)
    mna: MnaSystem
    spec: NetSpec

    @property
    def n_residuals(self) -> int:
        return 2 * self.z_meas.size

    def model(self, params: ParamSet, freq_hz: ArrF | None = None) -> ArrC:
        """Model impedances (n_f, n_t) (on ``freq_hz``, default the measured grid)."""
        f = self.freq_hz if freq_hz is None else freq_hz
        v = values_of(params, self.spec, "standstill")
        pairs = [TOPOLOGY_PORTS[t] for t in self.topologies]
        z = self.mna.response(f, pairs, pairs, v)
        zd = np.stack([z[:, i, i] for i in range(len(pairs))], axis=1)
        if "fixture_inductance" in self.spec.effects:
            zd = zd + 2j * np.pi * f[:, None] * params["fixture.L"]
        return zd

    def residual(self, params: ParamSet, names: Sequence[str] = (), jac: bool = False,
                 lmap: LogMap | None = None) -> tuple[ArrF, ArrF | None]:
        """``r`` (2 n_f n_t,) and, with ``jac``, ``dr/dx`` (2 n_f n_t, n_names); ``lmap``
        (for ``names``) saves recomputing the value map."""
        v = values_of(params, self.spec, "standstill")
        pairs = [TOPOLOGY_PORTS[t] for t in self.topologies]
        nt = len(pairs)
        if jac:
            dl = (lmap.at(params) if lmap is not None
                  else dlogv_dlogp(params, names, self.spec, "standstill"))
            used = _used_elements(dl)
            z, dzd = self.mna.response_and_jacobian(
                self.freq_hz, pairs, pairs, v,
                params=[self.mna.param_names[e] for e in used], diagonal=True)
            idx = np.arange(nt)
            zd = z[:, idx, idx]                                       # dzd: (f, t, used)
        else:
            z = self.mna.response(self.freq_hz, pairs, pairs, v)
            zd = np.stack([z[:, i, i] for i in range(nt)], axis=1)
        fix = "fixture_inductance" in self.spec.effects
        if fix:
            zd = zd + 2j * np.pi * self.freq_hz[:, None] * params["fixture.L"]
        lr = np.log(zd / self.z_meas) / self.sigma[None, :]
        r = np.concatenate([lr.real.ravel(), lr.imag.ravel()])
        if not jac:
            return r, None
        dzx = _chain(dzd, v[used], dl[used])                          # (f, t, n_names)
        if fix and "fixture.L" in names:
            j = list(names).index("fixture.L")
            dzx[:, :, j] += 2j * np.pi * self.freq_hz[:, None] * params["fixture.L"]
        dlr = dzx / zd[:, :, None] / self.sigma[None, :, None]
        jm = np.concatenate([dlr.real.reshape(-1, len(names)), dlr.imag.reshape(-1, len(names))])
        return r, jm


def impedance_term(spectra: dict[str, FrequencyData], spec: NetSpec, params: ParamSet,
                   topologies: Iterable[str] | None = None) -> ImpedanceTerm:
    """Condition-1 term of the spectra (all on one frequency grid, as in a dataset)."""
    topo = tuple(t for t in (topologies or spectra) if t in spectra)
    f0 = spectra[topo[0]].freq_hz
    for t in topo[1:]:
        if spectra[t].freq_hz.shape != f0.shape or not np.allclose(spectra[t].freq_hz, f0):
            raise ValueError("impedance spectra must share one frequency grid")
    z = np.stack([spectra[t].to_kind("Z").values[:, 0, 0] for t in topo], axis=1)
    # noise level per topology (std of log Z per real component), floored at 1e-4 so that
    # noiseless data keep finite weights
    sig = np.array([log_noise_sigma(z[:, i], floor=1e-4) for i in range(len(topo))])
    return ImpedanceTerm(topo, f0, z, sig, spec.build(params, "standstill").mna, spec)


# ----------------------------------------------------------------------------- condition 2
@dataclass(frozen=True)
class PreparedRecording:
    """A recording after the 10 MHz filter, its spectrum and its H1 transfer.

    The H1 estimate is computed on the filtered record resampled (exactly, by truncating
    its spectrum: it holds nothing above ``f_cut``) to ``fs_h1 >= 2.5 f_cut``; the Welch
    segments then span the same times and give the same frequency grid at a fraction of
    the cost. ``terminals``/``bearing`` keep the full rate (peaks, spectra).
    """

    speed_rpm: float
    fs: float
    terminals: ArrF       # (3, n) filtered
    bearing: ArrF         # (n,) filtered
    bins_hz: ArrF         # FFT bins 0..f_cut of the whole record
    x_bins: ArrC          # (3, n_bins) rfft of the terminals on those bins
    n_h1: int             # samples of the resampled record used for H1
    terminals_h1: ArrF    # (3, n_h1)
    h1: H1Result

    @property
    def n_samples(self) -> int:
        return int(self.terminals.shape[1])

    @property
    def fs_h1(self) -> float:
        return self.fs * self.n_h1 / self.n_samples

    @cached_property
    def terminal_noise_psd(self) -> ArrF | None:
        """:func:`vfmodel.greybox.input_noise.input_noise_psd` of the record, computed once
        (3-10 ms): every bearing term built on it with the input-noise bias reads it, and
        the detective builds one per network structure it tries."""
        return input_noise_psd(self)


def prepare_recording(rec: Recording, f_cut_hz: float = F_CUT_HZ,
                      nperseg: int | None = None) -> PreparedRecording:
    """Filter (brickwall), transform and H1-analyse a recording (paper Sec. II-C, III-C)."""
    fs = rec.fs
    x = brickwall_filter(rec.terminals, fs, f_cut_hz)
    for name, row in zip(("u_U", "u_V", "u_W"), x, strict=True):
        # a flat terminal channel leaves no H1 bin valid, which read as "u_B carries no
        # signal" and named the wrong channel
        if float(np.std(row)) <= 1e-9 * float(np.max(np.abs(row), initial=1e-300)):
            raise InputError("recorded channel carries no signal", source=rec.source,
                             place=f"{name} of the recording at "
                                   f"{float(rec.speed_rpm or 0.0):g} rpm",
                             found="a constant voltage", expected="a measured terminal voltage")
    n = x.shape[1]
    freq = sfft.rfftfreq(n, 1.0 / fs)
    sel = freq <= min(f_cut_hz, fs / 2)
    xb = sfft.rfft(x, axis=1)[:, sel]
    q = max(1, int(fs // (2.5 * f_cut_hz)))
    n_h1 = n // q
    xh = resample_periodic(xb, n, n_h1) if q > 1 else x
    if nperseg is not None and q > 1:
        nperseg = max(16, nperseg // q)
    y, yh = _output_at_h1_rate(rec.bearing, fs, f_cut_hz, sel, n_h1)
    h1 = h1_analysis(xh, yh, fs * n_h1 / n, nperseg=nperseg,
                     input_names=["u_U", "u_V", "u_W"], output_names=["u_B"])
    _require_signal(h1, "u_B", float(rec.speed_rpm or 0.0), rec.source)
    return PreparedRecording(float(rec.speed_rpm or 0.0), fs, x, y, freq[sel], xb, n_h1, xh,
                             h1)


def _output_at_h1_rate(y_raw: ArrF, fs: float, f_cut_hz: float, sel: NDArray[np.bool_],
                       n_h1: int) -> tuple[ArrF, ArrF]:
    """An output channel filtered (full rate) and resampled to the H1 rate ``n_h1``."""
    y = brickwall_filter(y_raw, fs, f_cut_hz)
    n = y.size
    yh = resample_periodic(sfft.rfft(y)[sel], n, n_h1) if n_h1 < n else y
    return y, yh


def prepare_output(prep: PreparedRecording, y_raw: ArrF, name: str,
                   f_cut_hz: float = F_CUT_HZ, source: str | None = None
                   ) -> PreparedRecording:
    """``prep`` with another output channel of the same record (e.g. ``u_B_DE``, ``i_CM``)
    in place of ``u_B``: the channel filtered and resampled as ``u_B`` is, and its H1 from
    the same terminal voltages with the same estimator settings (segment length, overlap,
    window), so that :func:`bearing_term` with that channel's :data:`RecordQuantity` treats
    it exactly as the bearing voltage (``bearing`` then holds this channel)."""
    full = sfft.rfftfreq(prep.n_samples, 1.0 / prep.fs)
    sel = full <= min(f_cut_hz, prep.fs / 2)
    y, yh = _output_at_h1_rate(np.asarray(y_raw, dtype=float), prep.fs, f_cut_hz, sel,
                               prep.n_h1)
    h1 = h1_analysis(prep.terminals_h1, yh, prep.fs_h1, nperseg=prep.h1.nperseg,
                     noverlap=prep.h1.noverlap, window=prep.h1.window,
                     input_names=["u_U", "u_V", "u_W"], output_names=[name])
    _require_signal(h1, name, prep.speed_rpm, source)
    return replace(prep, bearing=y, h1=h1)


def _require_signal(h1: H1Result, name: str, rpm: float, source: str | None) -> None:
    """InputError for an output channel without power where H1 is defined: a flat channel
    (a disconnected probe records zeros) has no transfer to compare, and its whitening
    would divide by zero (the detective ended in "Residuals are not finite" on such a
    ``u_B_DE``)."""
    if not np.any(np.nan_to_num(h1.gyy[h1.valid, 0]) > 0):
        raise InputError("recorded channel carries no signal", source=source,
                         place=f"{name} of the recording at {rpm:g} rpm",
                         found="zero power in every H1 bin", expected="a measured channel")


def steady_output(h_bins: ArrC, prep: PreparedRecording, *, for_h1: bool = False) -> ArrF:
    """Periodic steady-state model output from the transfer (n_bins, 1, 3) on the bins
    (full rate, or ``for_h1`` at the rate of the H1 record)."""
    return periodic_response(h_bins[:, :1, :], prep.x_bins, prep.n_samples,
                             prep.n_h1 if for_h1 else prep.n_samples)[0]


class RecordTransfer:
    """The network's bearing transfer on a record's FFT bins and the periodic output it
    gives; shared by the H1 term (:class:`BearingTerm`) and the waveform term
    (:class:`vfmodel.greybox.record_fit.RecordTerm`), which hold these attributes."""

    prep: PreparedRecording
    state: BearingState
    mna: MnaSystem
    b: ArrF
    cout: ArrF
    spec: NetSpec
    _memo: TransferMemo

    def transfer_bins(self, params: ParamSet) -> ArrC:
        """Network transfer (n_bins, 1, 3) on the record's FFT bins (the last one is kept:
        the Jacobian at the point just evaluated reuses it)."""
        v = values_of(params, self.spec, self.state, sources=True)
        return self._memo(self.mna, self.b, self.cout, v, self.prep.bins_hz)

    def cm_transfer(self, params: ParamSet, freq_hz: float = BEARING_C_REF_HZ) -> float:
        """``|sum_i H_i(f)|``: the bearing voltage per volt of common-mode terminal voltage
        at ``freq_hz`` (the three terminals driven alike), a direct solve at that one
        frequency. At 100 kHz, between the switching harmonics and the ringing, this is
        the network's capacitive bearing voltage ratio: the plateau level the rotating
        records fix, whatever the scale of the divider's capacitances."""
        v = values_of(params, self.spec, self.state, sources=True)
        h = self.mna.solve(np.array([float(freq_hz)]), self.b, self.cout, v).h
        return float(abs(np.sum(h[0, 0, :])))

    def use_low_rank(self, params: ParamSet, names: Sequence[str],
                     reuse: LowRankTransfer | None = None) -> bool:
        """Prepare the transfer for fits that move only ``names`` from ``params`` (the
        lubricant of one speed): a low-rank update of the network at ``params``
        (:mod:`vfmodel.circuit.lowrank`), used while the other elements keep their values.
        False when the form cannot be made (nothing moves, or a mutual coupling does).
        ``reuse``: a form made for another term of the same network (the previous speed's
        record) is taken as it is when it applies here (the same moving elements, the
        fixed ones at the same values, the same bins): its references hold for any values
        of the moving elements.

        The reference transfers come from sparse solves on every bin (~2 s for 10^4 bins
        of the PMSM network), not from the pole-residue form (~0.1 s): the update amplifies
        the reference's error where ``D^-1 + M`` is nearly singular (a moving element far
        from its reference value resonating with the network it sees), and the form's
        error, checked relative to the largest of the stacked responses (the impedances
        ``M`` of the touched nodes, up to ~1e7 ohm), reached 0.3-3 % of the bearing
        transfer at the fitted values of four of five speeds of independent bench 162
        (with the end-winding capacitance; exact references: 1e-8 to 5e-7). Check the
        result with :meth:`low_rank_error`."""
        self._memo.forget()
        v = values_of(params, self.spec, self.state, sources=True)
        moving = _used_elements(dlogv_dlogp(params, names, self.spec, self.state,
                                            sources=True))
        if reuse is not None and np.array_equal(reuse.moving, np.unique(moving)) and \
                reuse.applies(v, self.prep.bins_hz) and \
                reuse.h0.shape[1:] == (self.cout.shape[1], self.b.shape[1]):
            self._memo.lowrank = reuse
        else:
            self._memo.lowrank = low_rank_transfer(self.mna, self.b, self.cout, v,
                                                   self.prep.bins_hz, moving)
        return self._memo.lowrank is not None

    @property
    def low_rank(self) -> LowRankTransfer | None:
        """The low-rank form in use (:meth:`use_low_rank`), or None."""
        return self._memo.lowrank

    def low_rank_error(self, params: ParamSet) -> float:
        """Largest difference, over the record's bins, between the low-rank transfer at
        ``params`` and the network solved (:func:`vfmodel.circuit.transfer.transfer_on`),
        relative to the largest transfer; 0 without a low-rank form or where it does not
        apply."""
        lr = self._memo.lowrank
        v = values_of(params, self.spec, self.state, sources=True)
        if lr is None or not lr.applies(v, self.prep.bins_hz):
            return 0.0
        exact = transfer_on(self.mna, self.b, self.cout, v, self.prep.bins_hz)
        scale = max(float(np.max(np.abs(exact))), 1e-300)
        return float(np.max(np.abs(lr(v) - exact)) / scale)

    def drop_low_rank(self) -> None:
        """Solve the network again from now on (after the fit that moved ``names``)."""
        self._memo.forget()

    def output(self, params: ParamSet) -> ArrF:
        """Modelled bearing voltage at the record rate (periodic steady state, filtered
        inputs)."""
        return steady_output(self.transfer_bins(params), self.prep)


@dataclass(frozen=True)
class BearingTerm(RecordTransfer):
    """Condition 2 at one speed: measured H1 and the compiled network of that state."""

    prep: PreparedRecording
    state: BearingState
    op: H1Operator
    h_meas: ArrC          # (n_fm, 3) on the operator's bins
    sigma: ArrF           # (n_fm, 3)
    mna: MnaSystem
    b: ArrF
    cout: ArrF
    spec: NetSpec
    whiten: ArrC | None = None   # (n_fm, 3, 3) C^{-1/2} of "covariance" weighting, else None
    bias: ArrC | None = None     # (n_fm, 3, 3) input-noise bias I - G_nn G_xx^-1, else None
    quantity: RecordQuantity = BEARING_QUANTITY   # what ``cout`` measures (u_B unless told)
    _memo: TransferMemo = field(default_factory=TransferMemo, init=False, repr=False,
                                compare=False)

    @property
    def n_residuals(self) -> int:
        return 2 * self.h_meas.size

    def weigh(self, d: ArrC) -> ArrC:
        """Normalised differences (..., n_fm, 3) of H1 values: ``d / sigma`` (diagonal
        weighting) or ``C^{-1/2} d`` per bin (covariance weighting)."""
        if self.whiten is None:
            return np.asarray(d / self.sigma, dtype=complex)
        return np.asarray(np.einsum("fij,...fj->...fi", self.whiten, d), dtype=complex)

    @property
    def freq_hz(self) -> ArrF:
        return self.op.freq_hz[self.op.mask]

    def h1_model(self, params: ParamSet) -> ArrC:
        """H1 of the model output (same estimator as the measurement, eq. 21), with the
        input-noise bias of the measured H1 applied when the term models it."""
        return self.h1_of(steady_output(self.transfer_bins(params), self.prep, for_h1=True))

    def h1_of(self, y: ArrF) -> ArrC:
        """H1 (n_fm, 3) of output record(s) ``y`` (..., n_h1) from the measured inputs; with
        ``bias`` the row vectors are multiplied by ``I - G_nn G_xx^-1`` (see
        :func:`bearing_term`)."""
        h = self.op.apply(y)
        if self.bias is None:
            return h
        return np.asarray(np.einsum("...fi,fij->...fj", h, self.bias), dtype=complex)

    def _r(self, h1m: ArrC) -> ArrF:
        d = self.weigh(h1m - self.h_meas)
        return np.concatenate([d.real.ravel(), d.imag.ravel()])

    def residual(self, params: ParamSet, names: Sequence[str] = (), jac: bool = False,
                 lmap: LogMap | None = None, method: str = "auto",
                 ) -> tuple[ArrF, ArrF | None]:
        """``r`` and, with ``jac``, ``dr/dx``: ``method`` ``"adjoint"``, ``"fd"`` or ``"auto"``
        (forward differences for up to ``_FD_MAX`` parameters, else adjoint).

        ``adjoint``: ``dH/dx`` by the adjoint method on a coarse grid (every record bin up to
        ``_J_DENSE_HZ``, then log spaced to 1.5x the tested band), ``dH/H`` interpolated
        linearly onto every record bin (see :func:`output_derivatives`),
        turned into output derivatives ``dY = sum_i dH_i X_i`` and passed through the same
        H1 operator (the operator is linear). ``fd``: forward differences of the residual.
        """
        r = self._r(self.h1_model(params))
        if not jac:
            return r, None
        if not names:
            return r, np.zeros((r.size, 0))
        if method == "fd" or (method == "auto" and len(names) <= _FD_MAX):
            cols = []
            for n in names:
                x0 = params[n]
                step = _FD_STEP if x0 * np.exp(_FD_STEP) <= params.spec(n).upper \
                    else -_FD_STEP
                p1 = params.with_values({n: x0 * np.exp(step)}, clip=True)
                cols.append((self._r(self.h1_model(p1)) - r) / step)
            return r, np.stack(cols, axis=1)
        grid = jacobian_grid(self.prep.bins_hz, _J_TOP * self.freq_hz[-1])
        dy = output_derivatives(self.mna, self.spec, self.state, self.prep, params, names,
                                grid, self.transfer_bins(params), lmap, self._memo.lowrank,
                                quantity=self.quantity)
        dh1 = self.weigh(self.h1_of(dy))                              # (n_p, n_fm, 3)
        jm = np.concatenate([dh1.real.reshape(len(names), -1),
                             dh1.imag.reshape(len(names), -1)], axis=1).T
        return r, np.ascontiguousarray(jm)


def jacobian_grid(bins_hz: ArrF, top_hz: float, n_log: int = _J_LOG_POINTS) -> ArrF:
    """Frequencies (Hz) of the adjoint solves of a record Jacobian: every record bin up to
    ``_J_DENSE_HZ`` (the switching harmonics), then ``n_log`` log-spaced points to
    ``top_hz``. With ``dH/H`` interpolated (:func:`output_derivatives`) 100 points keep
    the Jacobian of the PMSM network within 0.2 % of central differences of direct solves
    (every column; 40 points: 0.7 %), but the cable and the two bearings of the
    independent benches (benches/independent.py) need more: on bench 105 with 100 points
    the lubricant fits at 300-500 rpm stopped after 6-18 evaluations at chi2_red 2100-3900
    (rotating peak error 5.5 % mean), with 300 or 600 points they fit (1.6 % and 1.9 %)."""
    grid = np.union1d(bins_hz[(bins_hz > 0) & (bins_hz <= _J_DENSE_HZ)],
                      np.geomspace(_J_DENSE_HZ, max(top_hz, 2 * _J_DENSE_HZ), n_log))
    return np.asarray(grid, dtype=float)


def output_derivatives(mna: MnaSystem, spec: NetSpec, state: BearingState,
                       prep: PreparedRecording, params: ParamSet, names: Sequence[str],
                       grid: ArrF, h_bins: ArrC, lmap: LogMap | None = None,
                       lowrank: LowRankTransfer | None = None,
                       quantity: RecordQuantity = BEARING_QUANTITY) -> ArrF:
    """``d y_model / d log p`` (n_names, n_h1): the transfer's derivatives (to ``quantity``,
    default the bearing voltage; ``h_bins`` must be its transfer) by the
    adjoint method on ``grid`` (Hz), applied to the record's terminal spectra and resampled
    to the H1 rate (the periodic response of :func:`steady_output` is linear in the
    transfer). The relative sensitivity ``dH / H`` is interpolated linearly onto every
    record bin (DC: the lowest grid value) and multiplied by ``h_bins``, the transfer
    (n_bins, 1, 3) on every record bin: it varies slowly across the resonances that make
    ``dH`` itself change sign between grid points.

    The derivative spectrum stops at the grid's top (zero above): the H1 term's grid ends
    at 1.5 times its highest tested bin, and what lies above reaches the tested bins only
    through the estimator window's leakage (bench 105: columns within 4.6e-6 (median) of
    those with ``dH/H`` held at its last grid value up to the record's 10 MHz, itself no
    more than a guess there; against central differences of direct solves the five most
    changed columns err by 0.05-0.13 % of their norm, before 0.08-0.14 %; a record
    Jacobian 15 % faster).

    ``lowrank``: when it applies to the values and its moving elements include every
    element the parameters move, the transfer and its derivatives on the grid come from
    it (the record bins nearest the grid points), not from sparse factorisations."""
    v = values_of(params, spec, state, sources=True)
    dl = (lmap.at(params) if lmap is not None
          else dlogv_dlogp(params, names, spec, state, sources=True))
    used = _used_elements(dl)
    if lowrank is not None and np.isin(used, lowrank.moving).all() \
            and lowrank.applies(v, prep.bins_hz):
        pos = np.searchsorted(lowrank.moving, used)          # moving is sorted (np.unique)
        k = np.unique(np.rint(np.interp(grid, prep.bins_hz,
                                        np.arange(prep.bins_hz.size))).astype(np.intp))
        grid = prep.bins_hz[k]
        hg, dh = lowrank.with_derivatives(v, k)
        dh = dh[..., pos]
    else:
        hg, dh = mna.response_and_jacobian(grid, list(SOURCES), [n for n, _ in quantity], v,
                                           params=[mna.param_names[e] for e in used])
        if len(quantity) > 1 or quantity[0][1] != 1.0:   # the weighted sum of the probes
            w = np.array([wk for _, wk in quantity], dtype=float)
            hg = np.einsum("fo...,o->f...", hg, w)[:, None]
            dh = np.einsum("fo...,o->f...", dh, w)[:, None]
    dhx = _chain(dh[:, 0, :, :], v[used], dl[used]).transpose(2, 1, 0)    # (n_p, 3, n_g)
    nb = int(np.searchsorted(prep.bins_hz, grid[-1], side="right"))  # bins to the grid's top
    fb = prep.bins_hz[:nb]
    fi = np.interp(fb, grid, np.arange(grid.size))
    i0 = np.clip(np.floor(fi).astype(int), 0, grid.size - 1)
    i1 = np.clip(i0 + 1, 0, grid.size - 1)
    w = fi - i0
    hgt = hg[:, 0, :].T                                           # (3, n_g)
    rel = dhx / np.where(hgt == 0, 1.0, hgt)
    dfine = (rel[..., i0] * (1 - w) + rel[..., i1] * w) * h_bins[:nb, 0, :].T  # (n_p, 3, nb)
    dyb = sum(dfine[:, i] * prep.x_bins[i, :nb] for i in range(prep.x_bins.shape[0]))
    return resample_periodic(dyb, prep.n_samples, prep.n_h1)


def bearing_term(prep: PreparedRecording, spec: NetSpec, params: ParamSet,
                 state: BearingState, f_min_hz: float = 5e3,
                 f_max_hz: float = F_CUT_HZ, model_error: float = 0.02,
                 min_coherence: float = 0.5,
                 weighting: H1Weighting = "diagonal",
                 input_noise: bool = False, max_input_noise: float = 0.2,
                 bin_step: int = 1,
                 quantity: RecordQuantity = BEARING_QUANTITY) -> BearingTerm:
    """Condition-2 term of one prepared recording.

    ``quantity``: the network quantity ``prep.h1`` measures (default the bearing voltage
    ``u_B``; another channel of the record via :func:`prepare_output`).

    Bins from ``f_min_hz`` to ``f_max_hz`` where the H1 estimate is valid and the multiple
    coherence is at least ``min_coherence``; ``model_error`` is the relative error floor
    ``eps`` of ``sigma``. ``bin_step`` keeps every ``bin_step``-th of those bins (the
    errors of neighbouring bins of a Hann-windowed estimate are correlated).

    ``weighting``: ``"diagonal"`` divides each component ``H_i`` by its own standard
    uncertainty ``sigma_i`` (``h_std`` and the floor), ignoring the correlation of the
    component errors. ``"covariance"`` whitens the three components of each bin with the
    full covariance of the H1 estimate, ``C = s^2 conj(G_xx)^-1 / (n_eff - 3) + eps^2
    diag(|H_i|^2)`` with the residual noise power ``s^2 = (1 - gamma^2) G_yy`` (Bendat &
    Piersol, sec. 9.3); real and imaginary parts of the whitened residual then have unit
    variance (with ``"diagonal"`` each has variance 1/2, the convention of ``h_std``). When
    the inputs are strongly correlated (the common-mode part of
    the terminal voltages dominates), the individual ``H_i`` are uncertain but their
    common-mode combination is not, and only the full covariance keeps that information.
    This matters at standstill, where the bearing voltage is near the noise level.

    ``input_noise``: model the bias of the measured H1 caused by noise on the measured
    terminal voltages (errors in the inputs). With input noise of spectral matrix
    ``G_nn`` (independent channels, diagonal) the measured estimate is
    ``H1 = H (G_xx - G_nn) G_xx^-1 = H (I - G_nn G_xx^-1)``, while the model output computed
    from the same noisy inputs gives ``H`` exactly; the term therefore multiplies the
    model's H1 by the same factor (Bendat & Piersol, sec. 9.2, bias of H1 by input noise).
    ``G_nn`` is estimated by :func:`vfmodel.greybox.input_noise.input_noise_psd`: from the
    bins between the lines of a periodic record (constant duty cycles, every PWM period
    alike), else from the record's stretches without switching (duty-cycle jitter); when
    neither gives an estimate the bias is not modelled. At standstill the terminal
    spectrum above ~7 MHz is only a few dB above the probe noise and the uncorrected fit
    lowers the transfer there (the ringing peak of the model then comes out ~10 % low).
    The factor holds in expectation, but ``G_nn`` is an estimate whose relative error
    enters the factor multiplied by ``G_nn / (G_xx - G_nn)``: bins where the input noise
    exceeds the fraction ``max_input_noise`` of the power of any input
    (``G_nn,ii / G_xx,ii``) are dropped.
    """
    check_choice("weighting", weighting, H1Weighting)
    if int(bin_step) != bin_step or bin_step < 1:
        raise InputError(f"bin_step: expected an integer >= 1, got {bin_step!r}")
    h1 = prep.h1
    f = h1.freq_hz
    coh = np.nan_to_num(h1.coherence[:, 0])
    mask = h1.valid & (f >= f_min_hz) & (f <= f_max_hz) & (coh >= min_coherence)
    if mask.sum() < 10:
        mask = h1.valid & (f >= f_min_hz) & (f <= f_max_hz)
    gnn = prep.terminal_noise_psd if input_noise else None
    if gnn is not None:
        # the bias model is first order in G_nn / G_xx: drop the bins where the input noise
        # is a sizable part of the input power (the top of the band at standstill)
        gx = np.real(np.diagonal(h1.gxx, axis1=1, axis2=2)).T           # (3, n_f)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.max(gnn / gx, axis=0)
        keep = mask & (ratio <= max_input_noise)
        if keep.sum() >= 10:
            mask = keep
    if bin_step > 1:
        keep_idx = np.flatnonzero(mask)[::bin_step]
        mask = np.zeros_like(mask)
        mask[keep_idx] = True
    op = h1_operator(prep.terminals_h1, prep.fs_h1, h1, mask)
    hm = h1.h[mask, 0, :]
    sd = h1.h_std[mask, 0, :]
    sig = np.sqrt(sd**2 + (model_error * np.abs(hm)) ** 2)
    sig = np.maximum(sig, 1e-12 * np.max(np.abs(hm)))
    whiten = None
    if weighting == "covariance":
        whiten = _whitening(h1, mask, hm, model_error)
    bias: ArrC | None = None
    if gnn is not None:
        bias = np.asarray(np.eye(3)[None] - gnn[:, mask].T[:, :, None]
                          * np.linalg.inv(h1.gxx[mask]), dtype=complex)
    mna = spec.build(params, state, sources=True).mna
    b = mna.input_matrix(list(SOURCES))
    cout = quantity_vector(mna, quantity)
    return BearingTerm(prep, state, op, hm, sig, mna, b, cout, spec, whiten, bias, quantity)


def _whitening(h1: H1Result, mask: NDArray[np.bool_], hm: ArrC, eps: float) -> ArrC:
    """``sqrt(2) C^{-1/2}`` (n_fm, 3, 3) of the H1 covariance plus the model-error floor
    (see :func:`bearing_term`): real and imaginary parts of the whitened difference have
    unit variance. Eigenvalues floored at ``1e-12`` of the largest of each bin."""
    s2 = h1.noise_power(mask)                                                    # (n_fm,)
    # dH1 = G_nx G_xx^-1 with E[G_nx^H G_nx] = s^2 conj(G_xx) (per averaged segment):
    # E[dH1_a dH1_b^*] = s^2 [conj(G_xx)^-1]_ab (the transpose of G_xx^-1)
    cov = s2[:, None, None] * np.conj(np.linalg.inv(h1.gxx[mask]))
    cov = 0.5 * (cov + np.conj(np.transpose(cov, (0, 2, 1))))
    idx = np.arange(hm.shape[1])
    cov[:, idx, idx] += (eps * np.abs(hm)) ** 2
    w, v = np.linalg.eigh(cov)
    w = np.maximum(w, 1e-12 * w[:, -1:])
    # C is the covariance of the complex values; real and imaginary part of the whitened
    # difference then each have variance 1/2: scale by sqrt(2) for unit variance
    out = np.einsum("fik,fk,fjk->fij", v, np.sqrt(2.0 / w), v.conj())
    return np.asarray(out, dtype=complex)
