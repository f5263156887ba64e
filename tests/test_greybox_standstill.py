"""Standstill identification: input-noise PSD of a periodic record, covariance-whitened H1
residual with the input-noise bias, and the 0 rpm peak on a small virtual bench."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.fft as sfft

from tests.conftest import load_script
from vfmodel.circuit.transfer import transfer_on
from vfmodel.core.io_dataset import read_dataset
from vfmodel.core.recording import Recording
from vfmodel.greybox.assembly import BEARING_NODE, SOURCES, default_params
from vfmodel.greybox.identify import identify
from vfmodel.greybox.input_noise import (
    input_noise_psd,
    periodic_lines,
    periodic_noise_psd,
    quiet_noise_psd,
)
from vfmodel.greybox.metrics import peak_v
from vfmodel.greybox.network import NetSpec
from vfmodel.greybox.objective import (
    PreparedRecording,
    bearing_term,
    prepare_recording,
)

P0 = default_params()
FS = 100e6
PERIOD = 5000          # samples of one period (50 us)
M = 8                  # periods per record


def _pwm_period(rng: np.random.Generator) -> np.ndarray:
    """One period (3, PERIOD) of three trapezoidal 0/270 V PWM phases, 50 ns edges."""
    t = np.arange(PERIOD)
    out = []
    for ph in range(3):
        on, off = sorted(rng.uniform(0.05, 0.95, 2) * PERIOD)
        up = np.clip((t - on) / 5.0, 0, 1)
        down = np.clip((t - off) / 5.0, 0, 1)
        out.append(270.0 * (up - down) + 0.0 * ph)
    return np.array(out)


def _record(sigma_x: float, sigma_y: float, seed: int) -> tuple[Recording, float]:
    """Periodic record of the standstill network (P0) with white noise on the terminals
    (``sigma_x`` V) and on the bearing voltage (``sigma_y`` V); returns it and the
    noise-free filtered bearing peak."""
    rng = np.random.default_rng(seed)
    x = np.tile(_pwm_period(rng), (1, M))
    n = x.shape[1]
    freq = sfft.rfftfreq(n, 1 / FS)
    mna = NetSpec().build(P0, "standstill", sources=True).mna
    h = transfer_on(mna, mna.input_matrix(list(SOURCES)), mna.output_matrix([BEARING_NODE]),
                    mna.values0, freq)
    y = sfft.irfft(np.einsum("fi,if->f", h[:, 0, :], sfft.rfft(x, axis=1)), n=n)
    clean_peak = peak_v(y, FS)
    xn = x + sigma_x * rng.standard_normal(x.shape)
    yn = y + sigma_y * rng.standard_normal(n)
    return Recording(FS, np.vstack([xn, yn]), ("u_U", "u_V", "u_W", "u_B"), 0.0), clean_peak


def _white_ratio(prep: PreparedRecording, sigma: float, f_lo: float) -> np.ndarray:
    """:func:`input_noise_psd` of ``prep`` from ``f_lo`` to 9.5 MHz over the density of
    white noise of standard deviation ``sigma``: one-sided ``2 sigma^2 / fs`` (the 10 MHz
    brickwall filter keeps the in-band density)."""
    g = input_noise_psd(prep)
    assert g is not None
    f = prep.h1.freq_hz
    band = (f > f_lo) & (f < 9.5e6)
    return np.asarray(g[:, band] / (2 * sigma**2 / FS))


def test_input_noise_psd_of_periodic_record() -> None:
    rec, _ = _record(2.0, 0.03, 0)
    prep = prepare_recording(rec)
    assert periodic_lines(prep) == M
    ratio = _white_ratio(prep, 2.0, 0.2e6)
    assert np.median(ratio) == pytest.approx(1.0, abs=0.05)
    assert np.all(np.abs(ratio - 1) < 0.5)   # 200 kHz moving mean of ~150 bins: ~8 % std
    # a record that is not periodic (noise only) has no line structure: no estimate
    rng = np.random.default_rng(1)
    noise = Recording(FS, rng.standard_normal((4, M * PERIOD)), rec.channels, 0.0)
    assert periodic_noise_psd(prepare_recording(noise)) is None


def _jittered(sigma_x: float, seed: int, ringing: bool = False) -> Recording:
    """The record of :func:`_record` with every period's edges drawn anew (duty-cycle
    jitter: not periodic), white noise ``sigma_x`` V on the terminals; ``ringing``: each
    edge followed by a 2 MHz oscillation of 10 % of the step decaying with 2 us (cable
    ringing)."""
    rng = np.random.default_rng(seed)
    x = np.hstack([_pwm_period(rng) for _ in range(M)])
    if ringing:
        t = np.arange(400) / FS
        ring = 0.1 * np.exp(-t / 2e-6) * np.sin(2 * np.pi * 2e6 * t)
        steps = np.diff(x, axis=1, prepend=x[:, :1])
        x = x + np.stack([np.convolve(row, ring)[: x.shape[1]] for row in steps])
    xn = x + sigma_x * rng.standard_normal(x.shape)
    y = 0.03 * rng.standard_normal(x.shape[1])
    return Recording(FS, np.vstack([xn, y]), ("u_U", "u_V", "u_W", "u_B"), 0.0)


@pytest.mark.parametrize(("seed", "ringing"), [(4, False), (5, False), (6, True)])
def test_input_noise_psd_of_record_that_is_not_periodic(seed: int, ringing: bool) -> None:
    # duty-cycle jitter: no line structure, the quiet stretches between the edges give the
    # noise; white noise of variance s^2 has the one-sided density 2 s^2 / fs in band.
    # With ringing after the edges (27 V at 2 MHz) the windows it reaches are not quiet:
    # measured over seeds 4-6 the median stays 0.96-1.00, at 2 MHz 0.81-1.08
    prep = prepare_recording(_jittered(2.0, seed, ringing))
    assert periodic_lines(prep) == 1
    assert periodic_noise_psd(prep) is None
    # computed once per record, what every bearing term on it reads
    assert prep.terminal_noise_psd is prep.terminal_noise_psd
    np.testing.assert_array_equal(prep.terminal_noise_psd, input_noise_psd(prep))
    ratio = _white_ratio(prep, 2.0, 0.5e6)
    # half-overlapping 5 us windows of a 400 us record, the quiet ones averaged: ~10 % std
    # per 200 kHz bin (measured over seeds 4-8: 0.10-0.11, extremes 0.68-1.38)
    assert np.median(ratio) == pytest.approx(1.0, abs=0.05)
    assert np.all(np.abs(ratio - 1) < 0.5)
    # on a periodic record the two estimates agree
    prep_p = prepare_recording(_record(2.0, 0.03, seed)[0])
    gp, gq = periodic_noise_psd(prep_p), quiet_noise_psd(prep_p)
    assert gp is not None and gq is not None
    f = prep_p.h1.freq_hz
    band = (f > 0.5e6) & (f < 9.5e6)
    assert np.median(gq[:, band] / gp[:, band]) == pytest.approx(1.0, abs=0.05)


def test_quiet_noise_psd_needs_quiet_windows() -> None:
    # edges every 2 us in every window (a 500 kHz square wave on all phases): no stretch
    # is quiet, no estimate (rather than the switching taken for noise)
    t = np.arange(M * PERIOD)
    sq = 270.0 * ((t // 100) % 2)
    rng = np.random.default_rng(6)
    x = np.vstack([sq, sq, sq]) + rng.standard_normal((3, t.size))
    rec = Recording(FS, np.vstack([x, rng.standard_normal(t.size)]),
                    ("u_U", "u_V", "u_W", "u_B"), 0.0)
    assert quiet_noise_psd(prepare_recording(rec)) is None


@pytest.mark.parametrize("seed", [2, 3])
def test_covariance_whitening_at_the_true_network(seed: int) -> None:
    # output noise at the level of the signal (standstill SNR), noise-free terminals: the
    # true network's residual whitened with the full H1 covariance has unit variance per
    # real component (expected chi2_red 1; the covariance estimated from ~22 Welch
    # averages and the bin-to-bin correlation of the Hann window scatter it by ~10 %);
    # the diagonal weighting gives 1/2 (complex variance h_std^2 per real component)
    rec, _ = _record(0.0, 0.03, seed)
    prep = prepare_recording(rec)
    spec = NetSpec()
    chi = {}
    for w in ("diagonal", "covariance"):
        term = bearing_term(prep, spec, P0, "standstill", model_error=0.0,
                            weighting=w)
        r, _ = term.residual(P0)
        chi[w] = float(r @ r) / r.size
    assert chi["covariance"] == pytest.approx(1.0, abs=0.2)
    assert chi["diagonal"] == pytest.approx(0.5, abs=0.1)


@pytest.mark.parametrize("seed", [2, 3])
def test_input_noise_bias_at_the_true_network(seed: int) -> None:
    # terminal noise 3 V rms: the PWM spectrum near 10 MHz is then only a few dB above
    # the noise and the measured H1 is biased low there; the true network fits its own
    # data only when the term carries that bias
    rec, _ = _record(3.0, 0.03, seed)
    prep = prepare_recording(rec)
    spec = NetSpec()
    chi = {}
    for bias in (False, True):
        # max_input_noise=inf: the same bins with and without the bias model
        term = bearing_term(prep, spec, P0, "standstill", model_error=0.0,
                            weighting="covariance", input_noise=bias,
                            max_input_noise=np.inf)
        r, _ = term.residual(P0)
        chi[bias] = float(r @ r) / r.size
    # default: bins where the input noise exceeds 20 % of an input's power are dropped
    g = input_noise_psd(prep)
    assert g is not None
    term = bearing_term(prep, spec, P0, "standstill", weighting="covariance",
                        input_noise=True)
    gx = np.real(np.diagonal(prep.h1.gxx, axis1=1, axis2=2)).T
    ratio = np.max(g / gx, axis=0)
    assert np.all(ratio[term.op.mask] <= 0.2)
    assert term.op.mask.sum() < nobias_bins(prep, spec)
    # measured: seed 2: 1.91 -> 1.22, seed 3: 1.60 -> 1.08 (the input noise also adds
    # variance that the output-noise covariance does not hold: chi2 stays above 1)
    assert chi[True] < 1.35
    assert chi[False] > 1.3 * chi[True]


def nobias_bins(prep: PreparedRecording, spec: NetSpec) -> int:
    """Bins of the term without the input-noise model (no bins dropped)."""
    t = bearing_term(prep, spec, P0, "standstill")
    return int(t.op.mask.sum())


@pytest.fixture(scope="module")
def small_bench(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, object]]:
    ds = tmp_path_factory.mktemp("standstill") / "bench"
    truth = load_script("make_testbench").make_bench(
        ds, seed=2, speeds=(0.0,), periods=4, n_freq=81, n_coils=2, n_rungs=4)
    return ds, truth


def test_standstill_peak_on_small_bench(small_bench: tuple[Path, dict[str, object]]) -> None:
    ds, truth = small_bench
    data = read_dataset(ds)
    recs = truth["recordings"]
    assert isinstance(recs, dict)
    clean = recs["0"]["peak_u_b_clean_v"]      # bench's noise-free peak (0.499 V)
    errs = {}
    for label, kw in (("new", {}),
                      ("whole waveform", {"standstill_fit": "record"}),
                      ("diagonal H1, no input-noise bias, C_rf free",
                       {"standstill_fit": "h1", "standstill_weighting": "diagonal",
                        "input_noise": False,
                        "hold_standstill": ()})):
        ident = identify(data, sections=(2,), max_nfev=30, **kw)
        sf = ident.speeds[0]
        assert sf.state == "standstill"
        prep = sf.term.prep
        pk_meas = peak_v(prep.bearing, prep.fs, filtered=True)
        pk_model = peak_v(sf.term.output(sf.params), prep.fs, filtered=True)
        errs[label] = (abs(pk_model - pk_meas), pk_model)
    abs_err, pk_model = errs["new"]
    # issue 7 target: absolute peak error at 0 rpm <= 0.08 V (measured 0.022 V)
    assert abs_err <= 0.08
    # against the bench's noise-free peak (not used by the pipeline): within 8 %
    # (measured +3.7 %; the H1 alone, the method before 2026-11-24: +3.6 %)
    assert abs(pk_model / clean - 1) < 0.08
    # the waveform over the whole band, with the terminals near the probe noise at the
    # top of the band, is biased low like an uncorrected H1 (measured -14.6 %): the
    # default takes the band above 1 MHz from the bias-corrected H1
    assert errs["whole waveform"][1] / clean - 1 < -0.08
    # the per-component H1 weighting lets the terminal-noise bias pull the transfer low
    # (measured 0.353 V, error 0.144 V)
    assert errs["diagonal H1, no input-noise bias, C_rf free"][0] > 0.08
