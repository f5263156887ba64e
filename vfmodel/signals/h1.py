"""Multi-input H1 transfer estimator (Welch averaging), coherences, uncertainty.

Model (paper eqs. 6-18): at every frequency ``Y = H X + N`` with inputs ``X`` (n_in),
outputs ``Y`` (n_out) and noise ``N`` on the outputs only, uncorrelated with the inputs.
Least squares over the Welch segments gives ``G_yx = H G_xx``, i.e.
``H1 = G_yx G_xx^{-1}`` with the averaged spectral matrices
``G_xx[i, j] = E[X_i X_j^*]`` and ``G_yx[o, j] = E[Y_o X_j^*]``.

Coherences (Bendat & Piersol, ch. 7):

- multiple coherence of output ``o``: ``gamma^2_{y:x} = (H G_xy)_{oo} / G_yy,o``, the
  fraction of the output power explained linearly by all inputs together;
- ordinary coherence of input ``j``: ``|G_yx[o, j]|^2 / (G_xx[j, j] G_yy,o)``.

Uncertainty: the least-squares covariance of ``H`` with the noise power estimated from the
residual, ``E|H1 - H|^2 = (1 - gamma^2) G_yy [G_xx^{-1}]_jj / (n_eff - n_in)`` (Bendat &
Piersol, sec. 9.3; n_eff: the number of statistically independent averages, reduced by the
segment overlap according to Welch's variance formula). For small errors the relative
error of ``|H|`` and the phase error (rad) each have standard deviation
``h_std / (sqrt(2) |H|)``.

References
----------
J. S. Bendat, A. G. Piersol, *Random Data: Analysis and Measurement Procedures*, 4th ed.,
Wiley, 2010, doi:10.1002/9781118032428 (ch. 7 multiple-input relations, ch. 9 errors).
P. D. Welch, "The use of fast Fourier transform for the estimation of power spectra",
IEEE Trans. Audio Electroacoust. 15(2), 1967, doi:10.1109/TAU.1967.1161901.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import scipy.fft as sfft
import scipy.signal as ss
from numpy.typing import ArrayLike, NDArray

from vfmodel.errors import IllConditionedWarning, InputError
from vfmodel.signals.checks import (
    as_channels,
    check_finite,
    check_fs,
    check_length,
    find_clipping,
    warn_clipping,
)

__all__ = [
    "H1Result",
    "default_nperseg",
    "h1_analysis",
    "h1_analysis_blocks",
    "h1_estimate",
    "welch_power",
]

Detrend = Literal["constant", "linear", "none"]
_SEG_BATCH = 64  # segments transformed at once (bounds the memory of one batch)


@dataclass(frozen=True)
class H1Result:
    """Everything :func:`h1_analysis` estimates; arrays are (frequency, out, in).

    Attributes
    ----------
    freq_hz : (n_f,)
    h : (n_f, n_out, n_in) complex; NaN where the inputs carry no power or are linearly
        dependent (see ``valid``).
    coherence : (n_f, n_out) multiple coherence.
    ordinary_coherence : (n_f, n_out, n_in)
    h_std : (n_f, n_out, n_in) standard uncertainty ``sqrt(E|H1 - H|^2)``.
    gxx : (n_f, n_in, n_in), gyx : (n_f, n_out, n_in), gyy : (n_f, n_out)
        One-sided spectral density matrices (V^2/Hz, same scaling as ``scipy.signal.csd``).
    cond : (n_f,) condition number of ``G_xx`` normalised to unit diagonal.
    valid : (n_f,) bool, where ``h`` was computed.
    n_averages : number of Welch segments; n_effective: independent averages (Welch 1967).
    """

    freq_hz: NDArray[np.float64]
    h: NDArray[np.complex128]
    coherence: NDArray[np.float64]
    ordinary_coherence: NDArray[np.float64]
    h_std: NDArray[np.float64]
    gxx: NDArray[np.complex128]
    gyx: NDArray[np.complex128]
    gyy: NDArray[np.float64]
    cond: NDArray[np.float64]
    valid: NDArray[np.bool_]
    n_averages: int
    n_effective: float
    nperseg: int
    noverlap: int
    window: str

    @property
    def mag_rel_std(self) -> NDArray[np.float64]:
        """Standard deviation of the relative error of ``|H|`` (small-error approximation)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.asarray(self.h_std / (np.sqrt(2) * np.abs(self.h)), dtype=float)

    @property
    def phase_std_deg(self) -> NDArray[np.float64]:
        """Standard deviation of the phase error in degrees (small-error approximation)."""
        return np.degrees(self.mag_rel_std)

    def noise_power(self, sel: Any, output: int = 0) -> NDArray[np.float64]:
        """``s^2 = (1 - gamma^2) G_yy / (n_eff - n_in)`` of ``output`` on the bins ``sel``:
        with ``conj(G_xx)^-1`` the covariance of the H1 row, ``E[dH_a dH_b^*] =
        s^2 [conj(G_xx)^-1]_ab`` (module docstring; ``h_std`` is its diagonal)."""
        dof = max(self.n_effective - self.gxx.shape[1], 1.0)
        coh = np.nan_to_num(self.coherence[sel, output])
        return np.asarray((1.0 - coh) * self.gyy[sel, output] / dof, dtype=float)


def default_nperseg(n: int) -> int:
    """Welch segment length of the H1 estimator (and of the spectral correlation) for a
    record of ``n`` samples."""
    # largest power of two giving >= ~15 half-overlapping segments, within [256, 65536]
    p = 2 ** int(np.floor(np.log2(max(n / 8, 1))))
    return int(min(max(p, 256), 65536, n))


def _check_welch(
    n: int | None, nperseg: int | None, noverlap: int | None, window: str, detrend: str
) -> tuple[int, int, NDArray[np.float64]]:
    if nperseg is None:
        if n is None:
            raise InputError("nperseg is required for streamed records", place="nperseg")
        nperseg = default_nperseg(n)
    if int(nperseg) != nperseg or nperseg < 2:
        raise InputError("nperseg must be an integer >= 2", place="nperseg", found=repr(nperseg))
    nperseg = int(nperseg)
    nov = nperseg // 2 if noverlap is None else int(noverlap)
    if not 0 <= nov < nperseg:
        raise InputError(
            "noverlap must satisfy 0 <= noverlap < nperseg",
            place="noverlap",
            found=repr(noverlap),
            expected=f"< {nperseg}",
        )
    if detrend not in ("constant", "linear", "none"):
        raise InputError(
            "unknown detrend", place="detrend", found=repr(detrend),
            expected="'constant', 'linear' or 'none'",
        )
    try:
        win = np.asarray(ss.get_window(window, nperseg), dtype=float)
    except ValueError as err:
        raise InputError(f"unknown window: {err}", place="window", found=repr(window)) from None
    return nperseg, nov, win


def welch_power(x: ArrayLike, nperseg: int | None = None,
                window: str = "hann") -> NDArray[np.float64]:
    """Welch average of ``|rfft(window * segment)|^2`` for each row of ``x``
    (channels x samples): half-overlapping segments (default length
    :func:`default_nperseg`), no detrending, unscaled (every bin alike). Returns
    (channels, nperseg // 2 + 1)."""
    buf = np.atleast_2d(np.asarray(x, dtype=float))
    n = buf.shape[1]
    nps, nov, win = _check_welch(n, nperseg, None, window, "none")
    if nps > n:
        raise InputError("nperseg is longer than the record", place="nperseg",
                         found=f"{nps} > {n} samples")
    step = nps - nov
    n_seg = (n - nps) // step + 1
    s = _segment_sum(buf, n_seg, nps, step, win, "none")
    return np.real(np.einsum("fcc->cf", s)) / n_seg


def _n_effective(win: NDArray[np.float64], step: int, k: int) -> float:
    """Welch (1967) eq. for the variance of an averaged periodogram with overlap:
    var ratio = (1/K) [1 + 2 sum_{j=1}^{K-1} (1 - j/K) rho(j)^2],
    rho(j) = sum w[n] w[n + j step] / sum w^2."""
    w2 = float(np.sum(win**2))
    acc = 0.0
    j = 1
    while j < k and j * step < win.size:
        rho = float(np.sum(win[: win.size - j * step] * win[j * step :])) / w2
        acc += (1 - j / k) * rho**2
        j += 1
    return k / (1 + 2 * acc)


def _segment_sum(
    buf: NDArray[Any], n_seg: int, nperseg: int, step: int, win: NDArray[np.float64],
    detrend: str,
) -> NDArray[np.complex128]:
    """Sum over ``n_seg`` segments of ``Z Z^H`` per frequency: (n_f, n_ch, n_ch)."""
    n_ch = buf.shape[0]
    n_f = nperseg // 2 + 1
    acc = np.zeros((n_f, n_ch, n_ch), complex)
    views = np.lib.stride_tricks.sliding_window_view(buf, nperseg, axis=1)[:, ::step]
    for s0 in range(0, n_seg, _SEG_BATCH):
        seg = np.asarray(views[:, s0 : min(n_seg, s0 + _SEG_BATCH)], dtype=float)
        if detrend == "constant":
            seg = seg - seg.mean(axis=-1, keepdims=True)
        elif detrend == "linear":
            seg = ss.detrend(seg, axis=-1, type="linear")
        z = sfft.rfft(seg * win, axis=-1)  # (n_ch, batch, n_f)
        zt = np.ascontiguousarray(z.transpose(2, 0, 1))  # (n_f, n_ch, batch)
        acc += zt @ zt.conj().transpose(0, 2, 1)
    return acc


def _finish(
    s_sum: NDArray[np.complex128],
    k: int,
    n_in: int,
    fs: float,
    nperseg: int,
    nov: int,
    win: NDArray[np.float64],
    window: str,
    detrend: str,
    cond_limit: float,
    place: str,
) -> H1Result:
    # scaling of scipy.signal.csd (density, one-sided)
    scale = 1.0 / (fs * float(np.sum(win**2)) * k)
    g = s_sum * scale
    if nperseg % 2:
        g[1:] *= 2
    else:
        g[1:-1] *= 2
    freq = sfft.rfftfreq(nperseg, 1 / fs)
    gxx = g[:, :n_in, :n_in]
    gyx = g[:, n_in:, :n_in]
    gyy = np.real(np.diagonal(g[:, n_in:, n_in:], axis1=1, axis2=2)).copy()
    dx = np.sqrt(np.maximum(np.real(np.diagonal(gxx, axis1=1, axis2=2)), 0))
    # bins without input power (relative to the strongest bin of each input)
    powered = np.all(dx > 1e-12 * np.max(dx, axis=0, initial=0.0)[None, :], axis=1)
    if detrend != "none":
        powered[0] = False  # DC removed by the detrend
    with np.errstate(divide="ignore", invalid="ignore"):
        norm = gxx / (dx[:, :, None] * dx[:, None, :])
    cond = np.full(freq.size, np.inf)
    if powered.any():
        cond[powered] = np.linalg.cond(norm[powered])
    valid = powered & (cond < cond_limit)
    collinear = powered & ~valid
    if collinear.any():
        fr = freq[collinear]
        warnings.warn(
            f"{place}: G_xx is ill-conditioned (normalised condition number >= "
            f"{cond_limit:.3g}) at {int(collinear.sum())} of {int(powered.sum())} frequencies "
            f"({fr.min():.6g}-{fr.max():.6g} Hz): the inputs are (nearly) linearly dependent, "
            "e.g. pure common-mode excitation u_U = u_V = u_W; H is set to NaN there. "
            "Excite independent inputs, or estimate the transfer from their mean (the "
            "common mode) as a single input",
            IllConditionedWarning,
            stacklevel=3,
        )
    n_f, n_out = freq.size, gyx.shape[1]
    h = np.full((n_f, n_out, n_in), np.nan + 0j)
    inv_diag = np.full((n_f, n_in), np.nan)
    if valid.any():
        # H G_xx = G_yx  <=>  G_xx^T H^T = G_yx^T, and G_xx^T = conj(G_xx) (Hermitian)
        h[valid] = np.linalg.solve(
            np.conj(gxx[valid]), gyx[valid].transpose(0, 2, 1)
        ).transpose(0, 2, 1)
        inv_diag[valid] = np.real(np.diagonal(np.linalg.inv(gxx[valid]), axis1=1, axis2=2))
    # multiple coherence from the pseudo-inverse so it is defined for dependent inputs too
    coh = np.full((n_f, n_out), np.nan)
    if powered.any():
        hp = gyx[powered] @ np.linalg.pinv(gxx[powered], rcond=1e-12, hermitian=True)
        with np.errstate(divide="ignore", invalid="ignore"):
            coh[powered] = np.real(np.sum(hp * np.conj(gyx[powered]), axis=2)) / gyy[powered]
    coh = np.clip(coh, 0.0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        ocoh = np.abs(gyx) ** 2 / (np.real(np.diagonal(gxx, axis1=1, axis2=2))[:, None, :]
                                   * gyy[:, :, None])
    n_eff = _n_effective(win, nperseg - nov, k)
    dof = n_eff - n_in
    with np.errstate(invalid="ignore"):
        var = ((1 - coh) * gyy)[:, :, None] * inv_diag[:, None, :] / dof if dof > 0 else None
    h_std = np.full(h.shape, np.inf) if var is None else np.sqrt(np.maximum(var, 0))
    h_std = np.where(valid[:, None, None], h_std, np.nan)
    return H1Result(
        freq_hz=freq, h=h, coherence=coh, ordinary_coherence=np.asarray(ocoh, dtype=float),
        h_std=h_std, gxx=gxx.copy(), gyx=gyx.copy(), gyy=gyy, cond=cond, valid=valid,
        n_averages=k, n_effective=float(n_eff), nperseg=nperseg, noverlap=nov,
        window=str(window),
    )


def _stack_io(
    inputs: ArrayLike, output: ArrayLike, input_names: list[str] | None,
    output_names: list[str] | None,
) -> tuple[NDArray[np.float64], int, list[str]]:
    xi, ni = as_channels(inputs, "inputs", input_names)
    xo, no = as_channels(output, "output", output_names)
    if xo.shape[1] != xi.shape[1]:
        raise InputError(
            "output and inputs have different lengths",
            place=f"output: channel {no[0]!r}",
            found=f"{xo.shape[1]} samples",
            expected=f"{xi.shape[1]} samples like input channel {ni[0]!r}",
        )
    return np.concatenate([xi, xo]), xi.shape[0], ni + no


def h1_analysis(
    inputs: ArrayLike,
    output: ArrayLike,
    fs: float,
    *,
    nperseg: int | None = None,
    noverlap: int | None = None,
    window: str = "hann",
    detrend: Detrend = "constant",
    cond_limit: float = 1e8,
    input_names: list[str] | None = None,
    output_names: list[str] | None = None,
) -> H1Result:
    """Multi-input/multi-output H1 estimate with coherences and uncertainty.

    Parameters
    ----------
    inputs : (n_in, n_samples) array_like, or a sequence of 1-D channels
    output : (n_samples,) or (n_out, n_samples) array_like
    fs : float
        Sample rate (Hz).
    nperseg : int, optional
        Welch segment length; default the largest power of two <= n/8 within [256, 65536].
    noverlap : int, optional
        Overlap of segments, default ``nperseg // 2``.
    window : str
        Any ``scipy.signal.get_window`` name (periodic), default Hann.
    detrend : {"constant", "linear", "none"}
        Per-segment detrending before windowing (as ``scipy.signal.csd``).
    cond_limit : float
        Frequencies where ``G_xx`` normalised to unit diagonal has a larger condition number
        get ``H = NaN`` and an :class:`IllConditionedWarning`.
    input_names, output_names : list of str, optional
        Channel names used in error and warning messages.

    Returns
    -------
    H1Result

    Raises
    ------
    InputError
        NaN/inf samples, channels of unequal length, or fewer samples than ``nperseg``
        (each message names the channel). Clipped channels give a ``SignalWarning``.
    """
    fs = check_fs(fs)
    z, n_in, names = _stack_io(inputs, output, input_names, output_names)
    n = z.shape[1]
    check_finite(z, names, "h1_analysis")
    nperseg_, nov, win = _check_welch(n, nperseg, noverlap, window, detrend)
    check_length(n, nperseg_, names, "h1_analysis", f"one Welch segment (nperseg={nperseg_})")
    warn_clipping(find_clipping(z, names), "h1_analysis")
    step = nperseg_ - nov
    k = (n - nperseg_) // step + 1
    s_sum = _segment_sum(z, k, nperseg_, step, win, detrend)
    return _finish(s_sum, k, n_in, fs, nperseg_, nov, win, window, detrend, cond_limit,
                   "h1_analysis")


def h1_estimate(
    inputs: ArrayLike, output: ArrayLike, fs: float, **kwargs: Any
) -> tuple[NDArray[np.float64], NDArray[np.complex128], NDArray[np.float64]]:
    """``freq_hz, H, coh`` (CONTRACT section 5): H1 transfer from inputs to output.

    For a single output (``output`` 1-D) ``H`` is (n_freq, n_in) and ``coh`` the multiple
    coherence (n_freq,); for ``output`` of shape (n_out, n) they are (n_freq, n_out, n_in)
    and (n_freq, n_out). Keyword arguments go to :func:`h1_analysis`, which also returns
    ordinary coherences and uncertainties.
    """
    res = h1_analysis(inputs, output, fs, **kwargs)
    if np.ndim(output) == 1:
        return res.freq_hz, res.h[:, 0, :], res.coherence[:, 0]
    return res.freq_hz, res.h, res.coherence


def h1_analysis_blocks(
    blocks: Iterable[ArrayLike],
    fs: float,
    *,
    n_in: int,
    nperseg: int,
    noverlap: int | None = None,
    window: str = "hann",
    detrend: Detrend = "constant",
    cond_limit: float = 1e8,
    names: list[str] | None = None,
) -> H1Result:
    """:func:`h1_analysis` of a long record streamed as blocks (bounded memory).

    Each block is an (n_in + n_out, n_block) array: the inputs first, then the outputs
    (e.g. slices of a float32 numpy memmap, or the blocks yielded by
    :func:`vfmodel.signals.filters.filter_blocks`). Segments spanning two blocks are handled;
    the result equals :func:`h1_analysis` of the concatenated record. Memory is of the
    order of one block plus one segment, independent of the record length.
    """
    fs = check_fs(fs)
    nperseg_, nov, win = _check_welch(None, nperseg, noverlap, window, detrend)
    step = nperseg_ - nov
    buf: NDArray[np.float64] | None = None
    s_sum: NDArray[np.complex128] | None = None
    k = 0
    pos = 0
    nm: list[str] = []
    clipped: dict[str, tuple[str, int, str, float]] = {}
    for blk in blocks:
        arr, nm_b = as_channels(np.asarray(blk), "block", names)
        if buf is None:
            nm = nm_b
            if not 1 <= n_in < arr.shape[0]:
                raise InputError(
                    "n_in must leave at least one output channel",
                    place="h1_analysis_blocks: n_in", found=repr(n_in),
                    expected=f"1..{arr.shape[0] - 1}",
                )
            buf = np.zeros((arr.shape[0], 0))
            s_sum = np.zeros((nperseg_ // 2 + 1, arr.shape[0], arr.shape[0]), complex)
        elif arr.shape[0] != buf.shape[0]:
            raise InputError(
                "blocks with different channel counts",
                place=f"h1_analysis_blocks: block at sample {pos}",
                found=f"{arr.shape[0]} channels", expected=f"{buf.shape[0]}",
            )
        check_finite(arr, nm, f"h1_analysis_blocks: block at sample {pos}")
        for f in find_clipping(arr, nm):
            clipped.setdefault(f[0], f)
        pos += arr.shape[1]
        buf = np.concatenate([buf, arr], axis=1)
        if buf.shape[1] >= nperseg_:
            n_seg = (buf.shape[1] - nperseg_) // step + 1
            assert s_sum is not None
            s_sum += _segment_sum(buf, n_seg, nperseg_, step, win, detrend)
            k += n_seg
            buf = buf[:, n_seg * step :].copy()
    if buf is None or s_sum is None:
        raise InputError("no samples", place="h1_analysis_blocks: blocks")
    check_length(pos, nperseg_, nm, "h1_analysis_blocks", f"one Welch segment (nperseg={nperseg_})")
    warn_clipping(list(clipped.values()), "h1_analysis_blocks")
    return _finish(s_sum, k, n_in, fs, nperseg_, nov, win, window, detrend, cond_limit,
                   "h1_analysis_blocks")
