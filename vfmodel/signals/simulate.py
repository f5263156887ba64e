"""Response of an LTI model to sampled inputs, exact in the frequency domain.

Two readings of the samples (``input_model``):

``"bandlimited"`` (default; oscilloscope records, filtered to 10 MHz)
    The samples are those of a band-limited signal (Shannon interpolation). The discrete
    transfer is ``H(j 2 pi f)`` for ``|f| < fs/2``; a derivative term ``s E`` becomes the
    discrete spectral derivative ``j w E``.
``"linear"`` (piecewise-linear sources, e.g. SPICE ``PWL``; RationalModel only)
    The input is linear between samples (first-order hold). For every pole the exact
    discretisation is used: ``1/(s - p)`` becomes
    ``G(z) = T [(z - 1) phi + psi] / (z - e^{pT})`` with ``psi = (e^{pT} - 1)/(pT)`` and
    ``phi = (e^{pT} - 1 - pT)/(pT)^2`` (triangle-hold equivalent, Franklin-Powell-Workman
    sec. 6.3), i.e. impulse response ``g[0] = T phi``, ``g[n] = T (phi (a - 1) + psi) a^{n-1}``
    with ``a = e^{pT}``. ``D`` is exact; ``s E`` becomes the central difference
    ``(x[n+1] - x[n-1]) / 2T`` (the mean of the left and right derivative at a kink).
    The result is the exact response at the sample instants.

Zero-state response (:func:`simulate`, :func:`simulate_blocks`): the input is zero before
the first and after the last sample. Products with ``H`` on an FFT grid are circular
convolutions; wrap-around is removed in two ways:

- every pole of a :class:`RationalModel` has a geometric (exponential) impulse-response
  tail; the part of it that wraps around the FFT window is computed in closed form and
  subtracted, and the tail beyond the window is carried to later blocks as a pole state.
  So slow poles (lubricant film time constants longer than the record) need no padding and
  are exact for any record length;
- the remaining, short part of the impulse response (the difference between the
  band-limited and the first-order-hold transfers, the derivative term, or a general
  callable ``H(f)``) is zero-padded by ``pad`` samples after and ``margin`` samples before
  each block. It is truncated there; that truncation is the only approximation.

Long records stream in blocks (overlap-add with FFT length ``fft_len``, default 2^20), so
memory is bounded by the block, not by the record length.

Periodic steady state (:func:`simulate_periodic`): the record is one period of a periodic
input (e.g. PWM in steady state); one FFT of the whole record, multiplied by ``H`` on its
grid, no padding. Exact for a periodic input and any pole time constant.

References
----------
G. F. Franklin, J. D. Powell, M. L. Workman, *Digital Control of Dynamic Systems*, 3rd ed.,
Addison-Wesley, 1998, sec. 6.3 (triangle-hold equivalent). A. V. Oppenheim, R. W. Schafer,
*Discrete-Time Signal Processing*, 3rd ed., 2010, sec. 8.7 (block convolution).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import scipy.fft as sfft
from numpy.typing import ArrayLike, NDArray

from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import InputError
from vfmodel.signals.checks import as_channels, check_finite, check_fs
from vfmodel.signals.periodic import periodic_response

__all__ = ["discrete_transfer", "simulate", "simulate_blocks", "simulate_periodic"]

InputModel = Literal["bandlimited", "linear"]
TransferLike = RationalModel | Callable[[NDArray[np.float64]], Any]
_FCHUNK = 32768  # frequencies per evaluation of H (bounds memory of the pole basis)
_TCHUNK = 8192  # samples per chunk of the geometric sums


@dataclass(frozen=True)
class _Poles:
    """FOH data of the poles: ``a = e^{pT}``, ``q = pT``, tail factor ``c`` and residues."""

    q: NDArray[np.complex128]
    a: NDArray[np.complex128]
    c: NDArray[np.complex128]  # g[n] = c a^{n-1}, n >= 1 (per unit residue)
    r: NDArray[np.complex128]  # (n_poles, n_out, n_in)


def _psi_phi(q: NDArray[np.complex128]) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """psi = expm1(q)/q and phi = (expm1(q) - q)/q^2, with series for small |q|."""
    psi = np.empty_like(q)
    phi = np.empty_like(q)
    small = np.abs(q) < 0.1
    qs = q[small]
    # psi = sum q^k/(k+1)!, phi = sum q^k/(k+2)!  (13 terms: error < 0.1^13/13!)
    ps = np.zeros_like(qs)
    ph = np.zeros_like(qs)
    for k in range(12, -1, -1):
        ps = ps * qs + 1 / _fact(k + 1)
        ph = ph * qs + 1 / _fact(k + 2)
    psi[small], phi[small] = ps, ph
    qb = q[~small]
    e = np.expm1(qb)
    psi[~small] = e / qb
    phi[~small] = (e - qb) / qb**2
    return psi, phi


def _fact(k: int) -> float:
    return float(np.prod(np.arange(1, k + 1, dtype=float)))


def _pole_data(model: RationalModel, fs: float) -> _Poles:
    t = 1.0 / fs
    q = model.poles * t
    psi, phi = _psi_phi(q)
    a = np.exp(q)
    return _Poles(q=q, a=a, c=t * (phi * (a - 1) + psi), r=model.residues)


def _check_model(model: Any, n_in: int) -> tuple[RationalModel | None, int]:
    if isinstance(model, RationalModel):
        if not np.all(model.poles.real < 0):
            bad = model.poles[model.poles.real >= 0][0]
            raise InputError(
                "model is not stable: a zero-state or steady-state response does not exist",
                place="simulate: model",
                found=f"pole {bad:.6g} rad/s with Re(p) >= 0",
                expected="every pole in the open left half plane",
            )
        if model.n_in != n_in:
            raise InputError(
                "number of inputs does not match the model",
                place="simulate: inputs",
                found=f"{n_in} channels",
                expected=f"{model.n_in} (model n_in)",
            )
        return model, model.n_out
    if not callable(model):
        raise InputError(
            "model must be a RationalModel or a callable H(freq_hz) -> (n_f, n_out, n_in)",
            place="simulate: model",
            found=type(model).__name__,
        )
    probe = np.asarray(model(np.array([0.0, 1.0])))
    if probe.ndim != 3 or probe.shape[0] != 2 or probe.shape[2] != n_in:
        raise InputError(
            "callable model returned a wrong shape",
            place="simulate: model(freq_hz)",
            found=f"shape {probe.shape} for 2 frequencies",
            expected=f"(2, n_out, {n_in})",
        )
    return None, int(probe.shape[1])


def discrete_transfer(
    model: TransferLike, fs: float, n_fft: int, input_model: InputModel = "bandlimited"
) -> NDArray[np.complex128]:
    """The discrete transfer on the ``rfft`` grid of length ``n_fft``: (n_f, n_out, n_in).

    ``"bandlimited"``: ``H(f_k)`` itself; ``"linear"`` (RationalModel only): the
    first-order-hold equivalent described in the module docstring.
    """
    fs = check_fs(fs)
    freq = sfft.rfftfreq(n_fft, 1 / fs)
    if input_model not in ("bandlimited", "linear"):
        raise InputError("unknown input_model", place="simulate: input_model",
                         found=repr(input_model), expected="'bandlimited' or 'linear'")
    if input_model == "linear" and not isinstance(model, RationalModel):
        raise InputError(
            "input_model='linear' needs a RationalModel (its poles give the exact "
            "first-order-hold transfer); use 'bandlimited' for a general callable",
            place="simulate: input_model",
        )
    parts = []
    if input_model == "linear":
        assert isinstance(model, RationalModel)
        q = model.poles / fs
        psi, phi = _psi_phi(q)
        e = np.expm1(q)
    for i0 in range(0, freq.size, _FCHUNK):
        f = freq[i0 : i0 + _FCHUNK]
        if input_model == "bandlimited" and isinstance(model, RationalModel):
            sj = 2j * np.pi * f
            g = 1.0 / (sj[:, None] - model.poles[None, :])
            h = np.einsum("fk,koi->foi", g, model.residues)
            parts.append(h + model.dd[None] + sj[:, None, None] * model.ee[None])
            continue
        if input_model == "bandlimited":
            parts.append(np.asarray(model(f), dtype=complex))
            continue
        assert isinstance(model, RationalModel)
        u = np.expm1(2j * np.pi * f / fs)  # z - 1 on the unit circle
        g = (u[:, None] * phi[None, :] + psi[None, :]) / (u[:, None] - e[None, :]) / fs
        h = np.einsum("fk,koi->foi", g, model.residues)
        deriv = 1j * fs * np.sin(2 * np.pi * f / fs)  # central difference
        parts.append(h + model.dd[None] + deriv[:, None, None] * model.ee[None])
    h_all = np.concatenate(parts, axis=0)
    if not np.all(np.isfinite(h_all)):
        k = int(np.argmax(~np.all(np.isfinite(h_all.reshape(h_all.shape[0], -1)), axis=1)))
        raise InputError(
            "model transfer is not finite on the FFT grid",
            place="simulate: model(freq_hz)",
            found=f"NaN/inf at {freq[k]:.6g} Hz",
            expected="finite H(f) for 0 <= f <= fs/2 (DC included: a pole at s = 0 has no "
            "zero-state or periodic response)",
        )
    return h_all


_LOG_TINY = -700.0  # e^-700 ~ 1e-304: below this a power is set to zero (no denormals)


def _powers(q: NDArray[np.complex128], expo: NDArray[np.float64]) -> NDArray[np.complex128]:
    """e^{q_k expo_i}: (n_poles, n_expo), exactly zero where it would underflow.

    Denormal numbers make exp and matrix products orders of magnitude slower, so
    negligible powers (``|.| < e^-700``) are flushed to zero explicitly.
    """
    arg = q[:, None] * expo[None, :]
    keep = arg.real > _LOG_TINY
    out = np.zeros(arg.shape, complex)
    out[keep] = np.exp(arg[keep])
    return out


def _chunk_powers(
    q: NDArray[np.complex128], base: NDArray[np.complex128], m0: float, cc: int
) -> NDArray[np.complex128]:
    """e^{q (m0 + i)} for i < cc from a precomputed ``base = e^{q i}`` (decaying),
    flushed to zero where the power is below e^-700."""
    pw = np.exp(q * m0)[:, None] * base[:, :cc]
    arg = q.real[:, None] * (m0 + np.arange(cc))[None, :]
    pw[arg <= _LOG_TINY] = 0.0
    return pw


def _geo_sum(
    w: NDArray[np.complex128], q: NDArray[np.complex128], m_len: int
) -> NDArray[np.float64]:
    """Re sum_k w[k, o] e^{q_k m} for m = 0..m_len-1: (n_out, m_len), in chunks."""
    out = np.zeros((w.shape[1], m_len))
    c = min(_TCHUNK, m_len)
    base = _powers(q, np.arange(c, dtype=float))
    for m0 in range(0, m_len, c):
        cc = min(c, m_len - m0)
        live = q.real * m0 > _LOG_TINY  # poles not yet decayed to nothing
        if not live.any():
            break
        pw = _chunk_powers(q[live], base[live], m0, cc)
        out[:, m0 : m0 + cc] = np.real(np.einsum("ko,kc->oc", w[live], pw))
    return out


def _weighted_state(
    x: NDArray[np.float64], q: NDArray[np.complex128], k_exp: int
) -> NDArray[np.complex128]:
    """S[k, i] = sum_j x[i, j] e^{q_k (k_exp - j)} (k_exp >= len - 1), in chunks."""
    n_in, n = x.shape
    s = np.zeros((q.size, n_in), complex)
    c = min(_TCHUNK, max(n, 1))
    base = _powers(q, np.arange(c, dtype=float))
    for j0 in range(0, n, c):
        cc = min(c, n - j0)
        e_last = k_exp - (j0 + cc - 1)  # smallest exponent of the chunk
        live = q.real * e_last > _LOG_TINY
        if not live.any():
            continue
        # exponent of sample j0 + i is e_last + (cc - 1 - i): reversed decaying powers
        pw = _chunk_powers(q[live], base[live], float(e_last), cc)[:, ::-1]
        s[live] += np.einsum("kc,ic->ki", pw, x[:, j0 : j0 + cc])
    return s


def _rechunk(blocks: Iterable[ArrayLike], size: int, n_in: int) -> Iterator[NDArray[np.float64]]:
    """Re-cut an iterator of (n_in, n) blocks into (n_in, size) pieces (the last shorter)."""
    pend: list[NDArray[np.float64]] = []
    have = 0
    pos = 0
    names = [f"inputs[{i}]" for i in range(n_in)]
    for blk in blocks:
        arr, _ = as_channels(np.asarray(blk), "inputs", names)
        check_finite(arr, names, f"simulate: block at sample {pos}")
        pos += arr.shape[1]
        pend.append(arr)
        have += arr.shape[1]
        while have >= size:
            cat = np.concatenate(pend, axis=1)
            yield cat[:, :size]
            pend = [cat[:, size:]]
            have -= size
    if have:
        yield np.concatenate(pend, axis=1)


def simulate_blocks(
    model: TransferLike,
    blocks: Iterable[ArrayLike],
    fs: float,
    *,
    n_in: int,
    input_model: InputModel = "bandlimited",
    margin: int | None = None,
    pad: int | None = None,
    fft_len: int = 2**20,
) -> Iterator[NDArray[np.float64]]:
    """Streaming zero-state response: yields (n_out, n) output blocks, in order.

    The yielded blocks together have exactly as many samples as the input stream.
    Memory is O(fft_len * (n_in + n_out)) independent of the record length.
    Parameters as in :func:`simulate` (``n_in``: channels per input block).
    """
    fs = check_fs(fs)
    rm, n_out = _check_model(model, n_in)
    a_len, p_len = _margins(rm, input_model, margin, pad, fft_len)
    n_fft = int(fft_len)
    b_len = n_fft - a_len - p_len
    if b_len < max(a_len, 1):
        raise InputError(
            "fft_len too small for the padding",
            place="simulate: fft_len",
            found=f"{fft_len} with margin {a_len} and pad {p_len}",
            expected=f">= {2 * a_len + p_len + 1}",
        )
    yield from _stream(rm if rm is not None else model, rm, _rechunk(blocks, b_len, n_in),
                       fs, n_in, n_out, input_model, a_len, p_len, n_fft)


def _margins(
    rm: RationalModel | None, input_model: str, margin: int | None, pad: int | None,
    fft_len: int,
) -> tuple[int, int]:
    if rm is not None and input_model == "linear":
        a_def, p_def = 1, 1  # only the central difference of E reaches beyond a sample
    elif rm is not None:
        a_def, p_def = 2048, 2048  # short band-limited correction (1/n tails)
    else:
        a_def, p_def = 2048, fft_len // 4
    a_len = a_def if margin is None else int(margin)
    p_len = p_def if pad is None else int(pad)
    if a_len < 1 or p_len < 1:
        raise InputError("margin and pad must be >= 1", place="simulate",
                         found=f"margin {margin!r}, pad {pad!r}")
    return a_len, p_len


def _stream(
    model: Any,
    rm: RationalModel | None,
    chunks: Iterator[NDArray[np.float64]],
    fs: float,
    n_in: int,
    n_out: int,
    input_model: InputModel,
    a_len: int,
    p_len: int,
    n_fft: int,
    n_total: int | None = None,
) -> Iterator[NDArray[np.float64]]:
    b_len = n_fft - a_len - p_len
    ov = a_len + p_len
    pdat = _pole_data(rm, fs) if rm is not None and rm.n_poles else None
    slow: _SlowPoles | None = None
    hgrid: NDArray[np.complex128] | None = None  # discrete transfer (n_f, n_out, n_in)
    if rm is not None and pdat is not None:
        # Poles whose tail barely decays over one FFT window (|1 - a^N| small) make the
        # closed-form wrap-around correction cancel catastrophically; they run as exact
        # first-order-hold recursions in the time domain instead (few, O(n) each).
        is_slow = np.abs(1 - np.exp(pdat.q * n_fft)) < 0.5
        if np.any(is_slow):
            slow = _SlowPoles.from_model(rm, is_slow, fs, n_in)
            sm = RationalModel(rm.poles[is_slow], rm.residues[is_slow], kind="H")
            fast = RationalModel(rm.poles[~is_slow], rm.residues[~is_slow], rm.d, rm.e,
                                 kind="H")
            # the fast part directly (subtracting the huge DC gain of a slow pole from the
            # full transfer would leave its rounding error in every sample)
            hgrid = discrete_transfer(fast, fs, n_fft, input_model)
            if input_model == "bandlimited":
                hgrid = hgrid + (discrete_transfer(sm, fs, n_fft, "bandlimited")
                                 - discrete_transfer(sm, fs, n_fft, "linear"))
            pdat = _subset(pdat, ~is_slow) if np.any(~is_slow) else None
    if hgrid is None:
        hgrid = discrete_transfer(model, fs, n_fft, input_model)
    slow_buf = np.zeros((n_out, 0))
    acc = np.zeros((n_out, ov))
    z_state = None if pdat is None else np.zeros((pdat.q.size, n_out), complex)
    skip = a_len  # output times before 0
    emitted_to = -a_len  # time of the next sample to emit
    end = 0  # number of input samples seen
    for x in chunks:
        lb = x.shape[1]
        end += lb
        if slow is not None:
            slow_buf = np.concatenate([slow_buf, slow.step(x)], axis=1)
        xpad = np.zeros((n_in, n_fft))
        xpad[:, a_len : a_len + lb] = x
        xf = sfft.rfft(xpad, axis=-1)  # (n_in, n_f)
        yf = np.einsum("foi,if->of", hgrid, xf)
        y = sfft.irfft(yf, n=n_fft, axis=-1)
        y[:, :ov] += acc
        if pdat is not None and z_state is not None:
            # wrap-around of the geometric pole tails (see module docstring)
            s = _weighted_state(x, pdat.q, n_fft - 1 - a_len)  # sum x a^{N-1-j}
            tail = pdat.c[:, None] * np.einsum("koi,ki->ko", pdat.r, s)  # T_k per output
            a_n = np.exp(pdat.q * n_fft)
            w1 = -tail / (1 - a_n)[:, None]
            w2 = w1 * np.exp(pdat.q * ov)[:, None] + z_state
            y[:, :ov] += _geo_sum(w1, pdat.q, ov)
            y[:, ov:] += _geo_sum(w2, pdat.q, n_fft - ov)
            z_state = z_state * np.exp(pdat.q * b_len)[:, None] + tail
        out = y[:, :b_len]
        acc = y[:, b_len:].copy()
        emitted_to += b_len
        if skip:
            k = min(skip, out.shape[1])
            out = out[:, k:]
            skip -= k
        if emitted_to > end:  # last (short) chunk: stop at the end of the record
            out = out[:, : max(out.shape[1] - (emitted_to - end), 0)]
        if out.shape[1]:
            if slow is not None:
                out = out + slow_buf[:, : out.shape[1]]
                slow_buf = slow_buf[:, out.shape[1] :]
            yield out
    if emitted_to < end:
        last = acc[:, : end - emitted_to]
        yield last + slow_buf[:, : last.shape[1]] if slow is not None else last


def _subset(p: _Poles, keep: NDArray[np.bool_]) -> _Poles:
    return _Poles(q=p.q[keep], a=p.a[keep], c=p.c[keep], r=p.r[keep])


@dataclass
class _SlowPoles:
    """Exact first-order-hold recursions of slow poles, state carried across blocks.

    Per unit residue the FOH impulse response is ``g[0] = T phi``, ``g[n] = c a^{n-1}``,
    i.e. ``G(z) = (T phi + (c - a T phi) z^-1) / (1 - a z^-1)``.
    """

    b: NDArray[np.complex128]  # (n_slow, 2)
    a: NDArray[np.complex128]  # (n_slow,)
    r: NDArray[np.complex128]  # (n_slow, n_out, n_in)
    zi: NDArray[np.complex128]  # (n_slow, n_in, 1)

    @classmethod
    def from_model(cls, rm: RationalModel, keep: NDArray[np.bool_], fs: float,
                   n_in: int) -> _SlowPoles:
        p = _pole_data(rm, fs)
        t = 1.0 / fs
        _, phi = _psi_phi(p.q[keep])
        a = p.a[keep]
        b = np.stack([t * phi, p.c[keep] - a * t * phi], axis=1)
        return cls(b=b, a=a, r=p.r[keep], zi=np.zeros((a.size, n_in, 1), complex))

    def step(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        from scipy.signal import lfilter

        y = np.zeros((self.r.shape[1], x.shape[1]), complex)
        for k in range(self.a.size):
            v, self.zi[k] = lfilter(self.b[k], [1.0, -self.a[k]], x, axis=-1, zi=self.zi[k])
            y += self.r[k] @ v
        return np.asarray(y.real, dtype=float)


def simulate(
    model: TransferLike,
    inputs: ArrayLike,
    fs: float,
    *,
    input_model: InputModel = "bandlimited",
    margin: int | None = None,
    pad: int | None = None,
    fft_len: int = 2**20,
) -> NDArray[np.float64]:
    """Zero-state response ``y`` (n_out, n_samples) of an LTI model to sampled inputs.

    Parameters
    ----------
    model : RationalModel or callable
        A stable :class:`RationalModel`, or any ``H(freq_hz) -> (n_f, n_out, n_in)``
        (e.g. a circuit transfer).
    inputs : (n_in, n_samples) or (n_samples,) array_like
        Input samples at rate ``fs``; zero before the first and after the last sample.
    fs : float
        Sample rate (Hz).
    input_model : {"bandlimited", "linear"}
        How the samples are read (module docstring); ``"linear"`` is the exact response to
        a piecewise-linear input (SPICE PWL) and needs a RationalModel.
    margin, pad : int, optional
        Samples of zero padding before/after each block for the part of the impulse
        response that is not a pole tail: band-limited correction (default 2048 each),
        or the whole impulse response of a general callable (``pad`` default
        ``fft_len // 4``: state it explicitly when the callable's impulse response is
        longer). Pole tails of a RationalModel are exact without padding.
    fft_len : int
        FFT length of a block for long records (a record that fits is done in one FFT of
        length ``next_fast_len(n + margin + pad)``).

    Returns
    -------
    ndarray (n_out, n_samples)

    Notes
    -----
    Exactness: for a RationalModel with ``input_model="linear"`` the result is exact (to
    rounding) at the sample instants for any record length and pole time constant. With
    ``"bandlimited"`` the only approximation is the truncation of the band-limited
    correction beyond ``margin``/``pad`` samples; for a general callable, the truncation of
    its impulse response beyond ``pad`` samples (and ``margin`` before 0).
    """
    fs = check_fs(fs)
    chans, names = as_channels(inputs, "inputs")
    check_finite(chans, names, "simulate")
    n_in, n = chans.shape
    if n == 0:
        raise InputError("no samples", place="simulate: inputs")
    rm, n_out = _check_model(model, n_in)
    a_len, p_len = _margins(rm, input_model, margin, pad, fft_len)
    n_fft = sfft.next_fast_len(n + a_len + p_len, real=True)
    if n_fft > fft_len:
        n_fft = int(fft_len)
    b_len = n_fft - a_len - p_len
    if b_len < max(a_len, 1):
        raise InputError("fft_len too small for the padding", place="simulate: fft_len",
                         found=f"{fft_len}", expected=f">= {2 * a_len + p_len + 1}")
    chunks = (chans[:, i : i + b_len] for i in range(0, n, b_len))
    out = np.empty((n_out, n))
    pos = 0
    for blk in _stream(model, rm, chunks, fs, n_in, n_out, input_model, a_len, p_len, n_fft):
        out[:, pos : pos + blk.shape[1]] = blk
        pos += blk.shape[1]
    assert pos == n
    return out


def simulate_periodic(
    model: TransferLike,
    inputs: ArrayLike,
    fs: float,
    *,
    input_model: InputModel = "bandlimited",
) -> NDArray[np.float64]:
    """Periodic steady-state response: the record is one period of a periodic input.

    One FFT of the whole record, multiplied by the (discrete) transfer on its grid, inverse
    FFT; no padding. Unlike :func:`simulate` (zero state: the system starts at rest) this is
    the response after all transients of earlier periods have settled, so poles with time
    constants far longer than the record (lubricant films) are handled exactly. The record
    should hold an integer number of periods (e.g. of the PWM carrier).
    """
    fs = check_fs(fs)
    chans, names = as_channels(inputs, "inputs")
    check_finite(chans, names, "simulate_periodic")
    n_in, n = chans.shape
    _check_model(model, n_in)
    h = discrete_transfer(model, fs, n, input_model)
    return periodic_response(h, sfft.rfft(chans, axis=-1), n)
