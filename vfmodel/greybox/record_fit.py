"""Condition 2 over the whole band: output-error fit of the recorded bearing voltage.

The H1 estimate (paper eq. 21) averages Welch segments: with 1-ms records (8 PWM periods)
its lowest bins lie at several segment frequencies and the switching-frequency range (the
capacitive plateau after each edge and the level between edges, 8 kHz to ~100 kHz) is
carried by a handful of noisy bins, while the ringing band has hundreds. A fit to H1 then
matches the ringing and leaves the plateau free. This term compares the waveform itself:

    r(t) = P [ y_model(t) - y_meas(t) ] / sigma,     t in the record's window,

with ``y_model`` the network transfer applied on every DFT bin of the whole record
(resolution 1/T, i.e. 1 kHz for 1 ms: every PWM harmonic and every bin between them up to
10 MHz) to the measured, filtered terminal voltages, and ``y_meas`` the filtered bearing
voltage, both at the reduced rate of the H1 record (nothing above 10 MHz is kept, so this
is exact). By Parseval this is the least-squares fit of the record's DFT bins with equal
weight per bin, i.e. weighted by the signal's own energy: the plateau (the PWM harmonics)
and the ringing count as much as they contribute to the waveform.

Records need not be periodic (PWM with duty jitter, records cut from a longer run): the
DFT model is the periodic response, and it differs from the response to the true input
history by a free response of the network (Pintelon & Schoukens' transient term), a sum
of decaying modes. The fast modes decay within microseconds: the first ``t_skip`` of the
record is left out (and the last ``t_end``, where the brickwall filter's Gibbs ringing of
the record's wrap-around sits). The slow modes (film time constants up to seconds) are
represented by a fixed basis (a constant and decaying exponentials with time constants
log-spaced from ``tau_min`` to ``tau_max``) and projected out (``P``): the fit cannot use
them to match the waveform, and an initial-state mismatch cannot bias the fit.

``sigma`` is the measurement noise of the filtered bearing voltage in the band, from the
H1 analysis (the median of ``(1 - gamma^2) G_yy`` above 200 kHz, taken as white noise,
times the band): the reduced chi-square
is then ~1 for a model at the noise, and larger with model error. Residual samples of a
band-limited record are correlated; :meth:`RecordTerm.correlation_factor` gives the
variance inflation ``1 + 2 sum rho_k`` of the residual (Bartlett), used for the
parameter uncertainties.

References
----------
R. Pintelon, J. Schoukens, *System Identification: A Frequency Domain Approach*, 2nd ed.,
Wiley-IEEE Press, 2012, ch. 6 (transient term of non-periodic records).
doi:10.1002/9781118287422
M. S. Bartlett, "On the theoretical specification and sampling properties of
autocorrelated time-series", J. R. Stat. Soc. Suppl. 8(1), 27-41, 1946.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.fft as sfft
from numpy.typing import NDArray

from vfmodel._choices import BearingState
from vfmodel.circuit.mna import MnaSystem
from vfmodel.circuit.transfer import TransferMemo
from vfmodel.greybox.assembly import BEARING_NODE, SOURCES
from vfmodel.greybox.metrics import T_END_S, T_SKIP_S, settled_window
from vfmodel.greybox.network import NetSpec
from vfmodel.greybox.objective import (
    LogMap,
    PreparedRecording,
    RecordTransfer,
    jacobian_grid,
    output_derivatives,
    steady_output,
    values_of,
)
from vfmodel.greybox.params import ParamSet
from vfmodel.signals.periodic import resample_periodic as _resample

__all__ = ["RecordTerm", "record_term"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]


@dataclass(frozen=True)
class RecordTerm(RecordTransfer):
    """Output-error term of one prepared recording (see the module docstring)."""

    prep: PreparedRecording
    state: BearingState
    spec: NetSpec
    mna: MnaSystem
    b: ArrF
    cout: ArrF
    y_meas: ArrF          # (n_h1,) filtered bearing voltage at the H1 rate
    window: slice         # samples of the record that are compared
    basis: ArrF           # (n_window, n_basis) orthonormal transient basis
    sigma: float          # noise std of one sample of y_meas
    taus: tuple[float, ...] = ()   # time constants of the transient basis (s)
    n_bins: int | None = None      # low-passed: the record bins kept (else all)
    stride: int = 1       # low-passed: every stride-th sample of the window compared
    _memo: TransferMemo = field(default_factory=TransferMemo, init=False, repr=False,
                                compare=False)

    @property
    def n_residuals(self) -> int:
        return len(range(self.window.start, self.window.stop, self.stride))

    def _project(self, d: ArrF) -> ArrF:
        """Remove the transient basis from (..., n_window) differences (low-passed: then
        every ``stride``-th sample)."""
        out = np.asarray(d - (d @ self.basis) @ self.basis.T, dtype=float)
        return out[..., :: self.stride] if self.stride > 1 else out

    def transfer_bins(self, params: ParamSet) -> ArrC:
        """Network transfer (n_bins, 1, 3) on the record's FFT bins; low-passed: solved
        on the bins compared only, zero above."""
        if self.n_bins is None:
            return super().transfer_bins(params)
        v = values_of(params, self.spec, self.state, sources=True)
        h = self._memo(self.mna, self.b, self.cout, v, self.prep.bins_hz[: self.n_bins])
        out = np.zeros((self.prep.bins_hz.size, *h.shape[1:]), dtype=complex)
        out[: self.n_bins] = h
        return out

    def raw_difference(self, params: ParamSet) -> ArrF:
        """``y_model - y_meas`` on the window after removing the transient (volts)."""
        ym = steady_output(self.transfer_bins(params), self.prep, for_h1=True)
        return self._project((ym - self.y_meas)[self.window])

    def residual(self, params: ParamSet, names: Sequence[str] = (), jac: bool = False,
                 lmap: LogMap | None = None) -> tuple[ArrF, ArrF | None]:
        """``r`` (n_window,) and, with ``jac``, ``dr/dx`` by the adjoint method on a grid
        (every bin up to 50 kHz, then log spaced), ``dH/H`` interpolated onto every record bin."""
        r = self.raw_difference(params) / self.sigma
        if not jac:
            return r, None
        if not names:
            return r, np.zeros((r.size, 0))
        bins = self.prep.bins_hz
        top = float(bins[-1] if self.n_bins is None else bins[self.n_bins - 1])
        dy = output_derivatives(self.mna, self.spec, self.state, self.prep, params, names,
                                jacobian_grid(bins, top), self.transfer_bins(params),
                                lmap, self._memo.lowrank)[:, self.window]
        jm = self._project(dy) / self.sigma
        return r, np.ascontiguousarray(jm.T)

    def _columns(self, t: ArrF) -> ArrF:
        return np.stack([np.ones(t.size)] + [np.exp(-t / tau) for tau in self.taus], axis=1)

    def transient(self, params: ParamSet) -> ArrF:
        """Estimated free response (full rate, whole record): the transient basis fitted
        to ``y_meas - y_model`` on the window, i.e. the initial-state correction."""
        ym = steady_output(self.transfer_bins(params), self.prep, for_h1=True)
        fs = self.prep.fs_h1
        tw = np.arange(self.window.start, self.window.stop) / fs
        coef, *_ = np.linalg.lstsq(self._columns(tw), (self.y_meas - ym)[self.window],
                                   rcond=1e-10)
        # before the window the decaying exponentials would be extrapolated (and
        # amplified): the correction is held at its value at the window start there
        t = np.maximum(np.arange(self.prep.n_samples) / self.prep.fs, tw[0])
        return np.asarray(self._columns(t) @ coef, dtype=float)

    def corrected_output(self, params: ParamSet) -> ArrF:
        """Modelled bearing voltage with the estimated initial-state correction."""
        return self.output(params) + self.transient(params)

    def correlation_factor(self, params: ParamSet, max_lag: int | None = None) -> float:
        """Variance inflation ``1 + 2 sum_k rho_k`` of the residual (Bartlett), >= 1.

        Summed over lags until the autocorrelation first drops below zero (or
        ``max_lag``, default 1 % of the window): the effective number of independent
        residual samples is ``n / factor``.
        """
        d = self.raw_difference(params)
        d = d - d.mean()
        n = d.size
        spec = sfft.rfft(d, n=2 * n)
        ac = sfft.irfft(np.abs(spec) ** 2, n=2 * n)[:n]
        if ac[0] <= 0:
            return 1.0
        rho = ac / ac[0]
        lim = max_lag or max(10, n // 100)
        tot = 0.0
        for k in range(1, min(lim, n - 1)):
            if rho[k] <= 0:
                break
            tot += float(rho[k])
        return max(1.0, 1.0 + 2.0 * tot)


def _band_noise_sigma(prep: PreparedRecording, f_min_hz: float = 200e3,
                      top_hz: float | None = None) -> float:
    """Std of the output noise of the filtered bearing voltage, assumed white in the band:
    the median of ``(1 - gamma^2) G_yy`` (one-sided PSD of the H1 analysis) above
    ``f_min_hz`` times the band (to ``top_hz``, default the record's top bin). Below
    ``f_min_hz`` the film's time constants (ms) exceed the Welch segments, the segments
    leak and the coherence understates the fit there: the median over the band above is
    robust to such bins and to the ringing peaks."""
    h1 = prep.h1
    f = h1.freq_hz
    coh = np.clip(np.nan_to_num(h1.coherence[:, 0]), 0.0, 1.0)
    psd = (1.0 - coh) * h1.gyy[:, 0]
    f_hi = prep.bins_hz[-1]
    band = (f >= min(f_min_hz, 0.1 * f_hi)) & (f <= f_hi) & h1.valid
    if band.sum() < 10:
        band = (f > 0) & (f <= f_hi)
    var = float(np.median(psd[band])) * (f_hi if top_hz is None else min(top_hz, f_hi))
    tot = float(np.var(prep.bearing))
    return float(np.sqrt(max(var, 1e-8 * tot, 1e-30)))


def record_term(prep: PreparedRecording, spec: NetSpec, params: ParamSet,
                state: BearingState, *, t_skip_s: float = T_SKIP_S, t_end_s: float = T_END_S,
                tau_min_s: float = 5e-6, tau_max_s: float = 10e-3,
                n_tau: int = 10, f_max_hz: float | None = None) -> RecordTerm:
    """Output-error term of one prepared recording (see the module docstring).

    ``t_skip_s``/``t_end_s``: record start and end left out (fast transients, filter
    wrap-around); ``tau_min_s``..``tau_max_s``, ``n_tau``: the transient basis.
    ``f_max_hz``: compare the waveforms low-passed there (model and record: the DFT bins
    up to it), sampled at about twice that frequency, at which white noise so limited
    stays uncorrelated from sample to sample.
    """
    fs = prep.fs_h1
    n = prep.n_h1
    spec_b = sfft.rfft(prep.bearing)[: prep.bins_hz.size]
    n_bins: int | None = None
    stride = 1
    if f_max_hz is not None and f_max_hz < prep.bins_hz[-1]:
        n_bins = max(2, int(np.searchsorted(prep.bins_hz, f_max_hz, side="right")))
        spec_b = spec_b.copy()
        spec_b[n_bins:] = 0.0
        stride = max(1, int(fs / (2.0 * float(prep.bins_hz[n_bins - 1]))))
    y = _resample(spec_b, prep.n_samples, n)
    win = settled_window(n, fs, t_skip_s=t_skip_s, t_end_s=t_end_s)
    t = np.arange(win.start, win.stop) / fs
    taus = tuple(float(x) for x in np.geomspace(tau_min_s, tau_max_s, n_tau))
    cols = [np.ones(t.size)] + [np.exp(-t / tau) for tau in taus]
    u, s, _ = np.linalg.svd(np.stack(cols, axis=1), full_matrices=False)
    basis = u[:, s > s[0] * 1e-8]
    mna = spec.build(params, state, sources=True).mna
    b = mna.input_matrix(list(SOURCES))
    cout = mna.output_matrix([BEARING_NODE])
    top = None if n_bins is None else float(prep.bins_hz[n_bins - 1])
    return RecordTerm(prep, state, spec, mna, b, cout, y, win, basis,
                      _band_noise_sigma(prep, top_hz=top), taus, n_bins, stride)
