"""Fits that hold on real files (issue 13): constant data, strict JSON, certificates that
agree with dense sampling, one data argument, active data, per-point relative accuracy.

References: the scikit-rf example files (as shipped with the installed package), the
public transistor file of data/vfbench (scikit-rf docs, BSD-3), analytic responses.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path
from typing import cast

import numpy as np
import pytest
import skrf
from numpy.typing import NDArray

from benches.skrf_reference import skrf_auto_fit_error
from vfmodel._choices import Kind
from vfmodel.cli.main import main as cli_main
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.io_spectrum import read_spectrum
from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import FitWarning, InputError
from vfmodel.fitting.artifacts import find_artifacts
from vfmodel.fitting.data_passivity import data_passivity
from vfmodel.fitting.model_json import model_to_json, read_model_json
from vfmodel.fitting.passivity import check_passivity, enforce_passivity, passivity_margin
from vfmodel.fitting.vectfit import vector_fit
from vfmodel.pipeline.fit_job import run_fit

SKRF_DATA = Path(skrf.__file__).parent / "data"
VFBENCH = Path(__file__).resolve().parents[1] / "data" / "vfbench"


def _dense_min_margin(model: object, f_lo: float, f_hi: float) -> float:
    """Smallest margin on 200,000 log points from 1e-4 f_lo to 1e4 f_hi and at 0 Hz."""
    w = 2 * np.pi * np.concatenate([[0.0], np.geomspace(f_lo * 1e-4, f_hi * 1e4, 200_000)])
    return float(np.min(passivity_margin(model, w)))  # type: ignore[arg-type]


# ---------------------------------------------------------------------- constant data
@pytest.mark.parametrize("name", ["short.s1p", "wr2p2,short.s1p", "tee.s3p"])
def test_constant_file_gives_pole_free_model(name: str, tmp_path: Path) -> None:
    data = read_spectrum(SKRF_DATA / name)
    # an ideal short repeats its value: it is data, not export padding
    assert find_artifacts(data).n_genuine == data.n_freq
    res = run_fit([data], passive=True)
    assert res.data.n_freq == data.n_freq
    assert res.model.n_poles == 0
    assert res.unconstrained_rel_rms_error < 1e-9
    assert res.passivity is not None and res.passivity.passive
    # tee.s3p is lossless to 6 digits (sigma = 1 + 6e-13): the nearest passive constant
    # is as close to the data as the data's own violation floor allows (1.2x, issue 13)
    floor = res.data_passivity.floor if res.data_passivity is not None else 0.0
    assert res.rel_rms_error <= 1.2 * max(res.unconstrained_rel_rms_error, floor) + 1e-15
    obj = model_to_json(res.model, res.fit, (1.0, 2.0), True)
    (tmp_path / "m.json").write_text(json.dumps(obj, allow_nan=False))
    back = read_model_json(tmp_path / "m.json")
    assert back.n_poles == 0
    np.testing.assert_allclose(back(data.freq_hz), res.model(data.freq_hz), atol=1e-12)


@pytest.mark.parametrize("kind", ["S", "Z"])
def test_pole_free_model_enforced_by_the_nearest_passive_constant(kind: Kind) -> None:
    # analytic reference: a rotated diag(1 + 1e-9, 0.5) (S) or diag(-1e-9, 2) plus a
    # lossless antisymmetric part (Z) is made passive by moving the one offending singular
    # value (eigenvalue) by 1e-9: the change is 1e-9 in the 2-norm, not the margin (1e-6)
    rot = np.array([[0.8, -0.6], [0.6, 0.8]])
    if kind == "S":
        d = rot @ np.diag([1 + 1e-9, 0.5]) @ rot.T
    else:
        d = rot @ np.diag([-1e-9, 2.0]) @ rot.T + np.array([[0.0, 0.3], [-0.3, 0.0]])
    model = RationalModel(np.zeros(0, complex), np.zeros((0, 2, 2), complex), d, kind=kind)
    fixed, check = enforce_passivity(model)
    assert check.passive and fixed.n_poles == 0
    assert np.linalg.norm(fixed.dd - d, 2) == pytest.approx(1e-9, rel=1e-3)
    if kind == "S":
        assert np.linalg.norm(fixed.dd, 2) <= 1.0
    else:
        np.testing.assert_allclose(fixed.dd - fixed.dd.T, d - d.T, atol=1e-15)
        assert np.linalg.eigvalsh(0.5 * (fixed.dd + fixed.dd.T))[0] >= 0.0


@pytest.mark.ngspice
def test_pole_free_model_in_ngspice() -> None:
    from vfmodel.circuit.ngspice import run_ac
    from vfmodel.circuit.synthesis import model_to_spice

    z = np.array([[3.0, 1.0], [1.0, 2.0]])  # a resistive T network
    data = FrequencyData(np.geomspace(1e3, 1e6, 20), np.repeat(z[None], 20, axis=0), kind="Z")
    model, report = vector_fit(data)
    assert model.n_poles == 0 and report.rel_rms_error < 1e-12
    net = "\n".join(["pole-free", model_to_spice(model, "const").strip(),
                     "X1 p1 p2 0 const", "I1 0 p1 DC 0 AC 1", "R2 p2 0 1e12"]) + "\n"
    res = run_ac(net, ["v(p1)", "v(p2)"], f_start_hz=1e3, f_stop_hz=1e6, points_per_decade=2)
    # unit current into port 1, port 2 open: v1 = Z11, v2 = Z21
    np.testing.assert_allclose(res.values[:, 0], 3.0, rtol=1e-6)
    np.testing.assert_allclose(res.values[:, 1], 1.0, rtol=1e-6)


# ---------------------------------------------------------------------- strict JSON
def test_band_to_infinity_written_as_null(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    src = SKRF_DATA / "ring slot measured.s1p"
    with warnings.catch_warnings():
        warnings.simplefilter("always", FitWarning)  # the CLI prints it on stderr
        status = cli_main(["fit", str(src), "--out", str(tmp_path), "--no-plot", "--quiet"])
    assert status == 0
    assert "far above the estimated noise floor" in capsys.readouterr().err
    # its 3-pole fit violates passivity up to infinity (sigma_max(D) = 1.5)
    out3 = tmp_path / "order3"
    assert cli_main(["fit", str(src), "--order", "3", "--out", str(out3), "--no-plot",
                     "--quiet"]) == 0
    for out in (tmp_path, out3):
        text = (out / "model.json").read_text()
        assert "Infinity" not in text and "NaN" not in text
        json.loads(text)
    obj = json.loads((out3 / "model.json").read_text())
    bands = obj["passivity"]["bands_hz"]
    assert obj["passive"] is False and bands and bands[-1][1] is None  # band to infinity
    assert obj["point_rel_rms_error"] > 0 and obj["passivity"]["data_floor"] == 0.0


# ---------------------------------------------------------------------- certificates
@pytest.mark.parametrize("name", ["wr2p2,line1.s2p", "wr2p2,delayshort.s1p", "ro,1.s1p"])
def test_certificate_agrees_with_dense_sampling(name: str) -> None:
    data = read_spectrum(SKRF_DATA / name)
    model, _ = vector_fit(data)
    f = data.freq_hz
    dense = _dense_min_margin(model, f[0], f[-1])
    for method in ("auto", "sampling"):
        check = check_passivity(model, method=method)
        # wr2p2,line1: sigma_max 1.000335 from 0 Hz up was certified passive before
        assert check.passive == (dense >= -1e-12), (method, dense, check)
    passive, check = enforce_passivity(model, data)
    assert check.passive
    assert _dense_min_margin(passive, f[0], f[-1]) >= -1e-12


@pytest.mark.parametrize("name", ["open.s2p", "wr2p2,line1.s2p", "ntwk1.s2p",
                                  "delay_short.s1p", "ring slot measured.s1p"])
def test_file_enforced_within_1_2x_of_its_fit(name: str) -> None:
    # noise-free, lossless data (sigma_max 1 to 1e-9): the default margin follows the fit
    # error (1e-6 fixed moved ntwk1/open 2000-10000x their 3-6e-10 fit error); models
    # above 1 only out of band (delay_short: sigma(D) 1.00015; ring slot measured:
    # sigma(D) 1.24 for samples below 0.92) are corrected through real poles added out
    # of band (before: 18x and 2.2x). The enforced model stays within 1.2x of max(fit
    # error, data floor) (issue 13) and is passive by dense sampling
    data = read_spectrum(SKRF_DATA / name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)  # ring slot measured: far from noise
        plain = run_fit([data], delay="auto")
        res = run_fit([data], delay="auto", passive=True)
    assert res.passivity is not None and res.passivity.passive
    floor = res.data_passivity.floor if res.data_passivity else 0.0
    assert res.unconstrained_rel_rms_error == plain.rel_rms_error
    assert res.rel_rms_error <= 1.2 * max(plain.rel_rms_error, floor)
    f = res.data.freq_hz
    assert _dense_min_margin(res.model, f[0], f[-1]) >= -1e-12


def test_out_of_band_poles_leave_the_response() -> None:
    # added real poles carry zero residues: the response is the same to rounding, at
    # least one decade above and below the band
    from vfmodel.fitting.out_of_band_poles import with_out_of_band_poles

    data = read_spectrum(SKRF_DATA / "ring slot measured.s1p")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        model, _ = vector_fit(data)
    ext = with_out_of_band_poles(model, data.freq_hz)
    f = data.freq_hz
    assert ext.n_poles == model.n_poles + 5
    added = np.array([p for p in ext.poles if not np.any(p == model.poles)])
    assert added.size == 5 and np.all(added.imag == 0)
    assert np.all(np.abs(added.real) >= 2 * np.pi * 0.1 * f[0] * 0.999)
    g = np.geomspace(f[0] / 10, f[-1] * 10, 500)
    assert np.max(np.abs(ext(g) - model(g))) <= 1e-14 * np.max(np.abs(model(g)))


# ---------------------------------------------------------------------- one data argument
def test_one_data_argument_everywhere() -> None:
    path = SKRF_DATA / "ro,3.s1p"
    net = skrf.Network(str(path))
    fd = read_spectrum(path)
    ref, _ = vector_fit(fd)
    for arg in (net, str(path), path):
        model, _ = vector_fit(arg)
        np.testing.assert_allclose(model(fd.freq_hz), ref(fd.freq_hz), rtol=1e-6, atol=1e-9)
        _out, check = enforce_passivity(ref, arg)
        assert check.passive
    back = ref.to_network(fd.freq_hz)
    assert isinstance(back, skrf.Network)
    np.testing.assert_allclose(back.s, ref(fd.freq_hz), rtol=1e-12)
    # the fit job too (a path raised AttributeError: it took only a list of FrequencyData)
    job = run_fit([fd])
    for arg in (net, str(path), path, [path]):
        res = run_fit(arg)
        np.testing.assert_allclose(res.model(fd.freq_hz), job.model(fd.freq_hz), rtol=1e-6,
                                   atol=1e-9)
    with pytest.raises(InputError, match=r"FrequencyData, a skrf\.Network or a path"):
        run_fit(42)


# ---------------------------------------------------------------------- active data
def test_active_transistor_recognised() -> None:
    path = VFBENCH / "BFU520_05V0_010mA_NF_SP.s2p"
    data = read_spectrum(path)
    dp = data_passivity(data)
    assert dp is not None and dp.active
    # |S21| of the amplifier is about 10-20 at 0.4-2 GHz
    assert dp.worst_violation > 5
    model, _ = vector_fit(data)
    with pytest.raises(InputError, match="active"):
        enforce_passivity(model, data)
    with pytest.raises(InputError, match="active"):
        run_fit([data], passive=True)
    res = run_fit([data])  # fitting an active device is fine
    assert res.rel_rms_error < 0.05 and res.passivity is not None
    assert not res.passivity.passive


def test_data_floor_of_a_projection() -> None:
    # S = 1.01 at every point of a 1-port: the nearest passive S is 1, distance 0.01/1.01
    f = np.linspace(1e6, 1e7, 10)
    dp = data_passivity(FrequencyData(f, np.full(10, 1.01 + 0j), kind="S"))
    assert dp is not None
    assert dp.floor == pytest.approx(0.01 / 1.01, rel=1e-12)
    assert dp.worst_violation == pytest.approx(0.01, rel=1e-9) and not dp.active
    # Z = [[1, 0], [0, -0.5]] (Hermitian part eigenvalue -0.5): distance 0.5 / sqrt(1.25)
    z = np.repeat(np.array([[1.0, 0.0], [0.0, -0.5]])[None], 10, axis=0)
    dz = data_passivity(FrequencyData(f, z, kind="Z"))
    assert dz is not None and dz.floor == pytest.approx(0.5 / np.sqrt(1.25), rel=1e-12)
    assert dz.active


# ---------------------------------------------------------------------- per-point accuracy
def _impedance(f: np.ndarray) -> np.ndarray:
    """Analytic impedance spanning decades: 1 nF to frame in parallel with a series
    R-L-C branch (resonance near 160 kHz) and a second, damped one near 2 MHz."""
    s = 2j * np.pi * f
    y = s * 1e-9 + 1 / (2.0 + s * 1e-3 + 1 / (s * 1e-9)) + 1 / (20.0 + s * 1e-5 + 1 / (s * 6e-10))
    return np.asarray(1 / y)


def test_relative_weighting_reaches_below_the_noise() -> None:
    f = np.geomspace(1e3, 1e7, 401)
    truth = _impedance(f)
    rng = np.random.default_rng(1)
    noisy = truth * (1 + 0.005 * (rng.standard_normal(f.size)
                                  + 1j * rng.standard_normal(f.size)) / np.sqrt(2))
    data = FrequencyData(f, noisy, kind="Z")
    model, report = vector_fit(data)
    assert report.weighting == "relative"
    e = np.abs(model(f)[:, 0, 0] - truth) / np.abs(truth)
    # 0.5 % noise per point: the model is closer to the truth than the noise
    assert np.sqrt(np.mean(e**2)) < 0.003
    assert report.point_rel_rms_error == pytest.approx(0.005, rel=0.25)
    _, uniform = vector_fit(data, weighting="uniform")
    assert uniform.point_rel_max_error > report.point_rel_max_error


def test_info_single_file(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main(["info", str(VFBENCH / "BFU520_05V0_010mA_NF_SP.s2p")]) == 0
    out = capsys.readouterr().out
    assert "S 2x2, z0 50 ohm, 37 points" in out and "ACTIVE data" in out
    assert cli_main(["info", str(SKRF_DATA / "ro,1.s1p"), "--json"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["n_points"] == 201 and obj["active"] is False and obj["spacing"] == "linear"


# ---------------------------------------------------------------------- delay
def _delayed_line(f: np.ndarray, tau: float) -> np.ndarray:
    """Causal 2-port: transmission 0.9 exp(-s tau) / (1 + s/w1), small reflections."""
    s = 2j * np.pi * f
    s21 = 0.9 * np.exp(-s * tau) / (1 + s / (2 * np.pi * 3e9))
    s11 = 0.05 / (1 + s / (2 * np.pi * 5e9))
    out = np.empty((f.size, 2, 2), complex)
    out[:, 0, 0] = out[:, 1, 1] = s11 * np.exp(-s * tau)
    out[:, 0, 1] = out[:, 1, 0] = s21
    return out


def test_delay_extraction_cuts_the_order() -> None:
    f = np.linspace(1e7, 5e9, 600)
    tau = 5e-9  # 25 phase turns over the band
    data = FrequencyData(f, _delayed_line(f, tau), kind="S")
    model, report = vector_fit(data, delay="auto")
    assert model.delay == pytest.approx(tau, rel=0.05)
    assert report.rel_rms_error < 1e-3
    # at equal error (issue 13: "cut the order substantially at equal error"): without the
    # delay, asked for the delayed model's error. Measured (session 35) over five OpenBLAS
    # kernels: 9 poles at 1.5e-4 against 58 (SkylakeX), 15 at 1.5e-4 against 58 (Haswell,
    # Zen), 15 at 7.5e-5 against 58 at 1.2e-4 (SandyBridge), 24 at 7.0e-5 against 170
    # (Prescott). Until session 35 this compared the plain automatic fit (57-58 poles)
    # with the delayed one at whatever error each reached (Haswell: 7 poles at 2.3e-4
    # against 57 at 3.5e-5) and asked for 5x; the delayed fit is now more accurate, 15
    # poles on three kernels
    plain, _ = vector_fit(data, delay="none", target_error=report.rel_rms_error)
    assert plain.n_poles >= 3.5 * model.n_poles
    check = check_passivity(model)
    if not check.passive:
        model, check = enforce_passivity(model, data)
    assert check.passive and model.delay == pytest.approx(tau, rel=0.05)


def test_far_note_reads_the_data_the_delayed_fit_saw(monkeypatch: pytest.MonkeyPatch
                                                    ) -> None:
    # the note on a fit far above its noise floor explains the error by the sampling and
    # the phase turns of the data the rational part fitted: with the delay taken out, the
    # delayed line's 25 turns (analytic: 5 ns over 5 GHz) are gone. A PIN-diode cell
    # fitted with its 13.6 ns delay out was told "the phase turns 137 times".
    from dataclasses import replace

    from vfmodel.fitting import _fit_report, vectfit
    from vfmodel.fitting._fit_setup import _phase_turns

    seen: list[tuple[FrequencyData, float]] = []
    real = vectfit._far_from_floor

    def spy(report, fd, **kw):  # type: ignore[no-untyped-def]
        seen.append((fd, kw["delay"]))
        return real(report, fd, **kw)

    monkeypatch.setattr(vectfit, "_far_from_floor", spy)
    f = np.linspace(1e7, 5e9, 600)
    data = FrequencyData(f, _delayed_line(f, 5e-9), kind="S")
    model, report = vector_fit(data, delay=5e-9)
    ((fitted, delay),) = seen
    assert delay == model.delay == 5e-9
    assert _phase_turns(data) > 24 and _phase_turns(fitted) < 1
    # the note itself, for a report far above its floor: no phase turns to blame, the
    # delay named
    far = replace(report, weighted_rel_rms_error=0.5, noise_floor=1e-4)
    (note,) = _fit_report._far_from_floor(far, fitted, limit=200, delay=5e-9).notes
    assert "phase turns" not in note and "delay of 5e-09 s taken out" in note, note


def test_delay_estimate_follows_the_transmission() -> None:
    # a 2-port whose reflections carry more energy than the transmission (a filter's
    # stopband): the common delay is the transmission's (the reflection has none)
    from vfmodel.fitting._fit_setup import _delay

    f = np.linspace(1e7, 5e9, 600)
    s = 2j * np.pi * f
    tau = 5e-9
    v = np.empty((f.size, 2, 2), complex)
    v[:, 0, 0] = v[:, 1, 1] = 0.9 / (1 + s / (2 * np.pi * 2e9))
    v[:, 0, 1] = v[:, 1, 0] = 0.3 * np.exp(-s * tau)
    est = _delay(FrequencyData(f, v, kind="S"), "auto")
    assert est == pytest.approx(tau, rel=1e-6)   # exact phase slope, no noise
    # a negligible transmission (< 1 % of the largest entry's energy) is not followed: the
    # largest entry's delay is taken (here a reflection delayed by 2 ns; its pole adds
    # about 1 / (2 pi 2 GHz) = 0.08 ns at low frequencies, less over the band)
    v[:, 0, 0] = v[:, 1, 1] = v[:, 0, 0] * np.exp(-s * 2e-9)
    v[:, 0, 1] = v[:, 1, 0] = 0.003 * np.exp(-s * tau)
    assert _delay(FrequencyData(f, v, kind="S"), "auto") == pytest.approx(2e-9, rel=0.05)


def test_delayed_line_enforcement_needs_few_programs() -> None:
    """The delayed-line model of test_delay_extraction_cuts_the_order (5-10 poles by the
    BLAS kernel, sigma_max up to 86 from 14 GHz up) is certified within 15 programs.

    With cuts alone it needed 10, 12, 17, 22 and 28 programs (OPENBLAS_CORETYPE Haswell,
    Nehalem, SkylakeX, Prescott, Sandybridge; the default budget is 30): the singular
    vectors rotate between programs and the violation returned at 32-40 GHz. Frequencies
    cut twice now get their exact condition (a semidefinite cone): 7-10 programs on the
    same five kernels."""
    f = np.linspace(1e7, 5e9, 600)
    data = FrequencyData(f, _delayed_line(f, 5e-9), kind="S")
    model, _ = vector_fit(data, delay="auto")
    assert not check_passivity(model).passive
    _, report = enforce_passivity(model, data)
    assert report.passive and report.iterations <= 15


def test_delay_that_does_not_cut_the_order_is_not_kept() -> None:
    # a 4-port resonant network (scripts/bench_pdn.py's generator, 40 poles, no delay)
    # whose phase turns 5 times: its 7 ps "group delay" fits 43 poles against 39 without
    # and leaves sigma(D) ~ 24 out of band; delay="auto" must return the plain fit
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "bench_pdn", Path(__file__).resolve().parents[1] / "scripts" / "bench_pdn.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    f, sp = mod.pdn_s(4, 40, 600, 0)
    data = FrequencyData(f, sp, kind="S")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        model, _ = vector_fit(data, delay="auto")
        plain, _ = vector_fit(data, delay="none")
    assert model.delay == 0.0 and model.n_poles == plain.n_poles
    assert float(np.linalg.svd(model.dd, compute_uv=False)[0]) < 2.0


@pytest.mark.ngspice
def test_delay_exported_as_lossless_lines(tmp_path: Path) -> None:
    from vfmodel.circuit.ngspice import run_ac

    f = np.linspace(1e7, 5e9, 600)
    src = tmp_path / "line.s2p"
    FrequencyData(f, _delayed_line(f, 5e-9), kind="S").to_network().write_touchstone(
        str(src.with_suffix("")))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        assert cli_main(["fit", str(src), "--out", str(tmp_path / "o"), "--no-plot",
                         "--quiet", "--spice", str(tmp_path / "m.cir")]) == 0
    obj = json.loads((tmp_path / "o" / "model.json").read_text())
    assert obj["delay_s"] == pytest.approx(5e-9, rel=0.05)
    model = read_model_json(tmp_path / "o" / "model.json")
    # S-parameter harness: 2 V source behind z0 at port 1, z0 load at port 2:
    # S11 = V(p1) - 1, S21 = V(p2)
    net = "\n".join(["delay harness", (tmp_path / "m.cir").read_text().strip(),
                     "X1 p1 p2 0 vfmodel", "V1 s 0 DC 0 AC 2", "R1 s p1 50",
                     "R2 p2 0 50"]) + "\n"
    res = run_ac(net, ["v(p1)", "v(p2)"], f_start_hz=1e7, f_stop_hz=5e9,
                 points_per_decade=40)
    ref = model(res.freq_hz)
    np.testing.assert_allclose(res.values[:, 1], ref[:, 1, 0], atol=1e-4)
    np.testing.assert_allclose(res.values[:, 0] - 1, ref[:, 0, 0], atol=1e-4)


# ---------------------------------------------------------------------- noise-free data
def _skrf_auto_fit_error(name: str, data: FrequencyData) -> float:
    """Relative RMS error of scikit-rf's ``auto_fit`` on the file ``name`` (same measure
    as vfmodel's ``rel_rms_error``)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return skrf_auto_fit_error(str(SKRF_DATA / name), data.values, data.freq_hz)


@pytest.mark.parametrize("name", ["ntwk1.s2p", "open.s2p", "short.s2p", "wr2p2,line.s2p"])
def test_noise_free_file_as_accurate_as_scikit_rf(name: str) -> None:
    # simulated (noise-free) files: the out-of-band anchors and the ridge that hold the
    # poles in place cap the accuracy near 1e-7; the last relocation with lighter ones
    # must reach scikit-rf's auto_fit on the same file (same error measure, 1.1x or 1e-9).
    # wr2p2,line: a growth step 9 -> 13 poles fitting worse is retried with one pair
    # (before: a 'plateau' at 8 poles, 2.1e-6 against scikit-rf's 8.0e-7)
    data = read_spectrum(SKRF_DATA / name).to_kind("S")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, rep = vector_fit(data, delay="auto")
    assert rep.rel_rms_error <= max(1.1 * _skrf_auto_fit_error(name, data), 1e-9)
    # reference: the same fit held by the anchors to the end (no lighter relocation, the
    # order's one-pole-less trials judged in the anchored problem): at least as accurate
    _, anchored = vector_fit(data, delay="auto", out_of_band_weight=1e-4)
    assert rep.rel_rms_error <= anchored.rel_rms_error


def test_turning_reflection_is_not_a_plateau(tmp_path: Path) -> None:
    # the S11 of scikit-rf's microstrip model alone (0.5-1.6 % reflection whose phase turns
    # 3.3 times over 100 points) gains little until the order resolves the turns: the
    # growth stopped at 8 poles with 24 % error (warning, exit 0) where scikit-rf's
    # auto_fit reaches 1.2 %; reference: auto_fit on the same 1-port file, 1.1x
    src = VFBENCH / "mlin,djordjevicsvensson,kirschning.s2p"
    one = skrf.Network(str(src)).s11
    one.write_touchstone(str(tmp_path / "s11"))
    path = tmp_path / "s11.s1p"
    data = read_spectrum(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, rep = vector_fit(data, delay="auto")
        ref = skrf_auto_fit_error(str(path), data.values, data.freq_hz)
    assert ref < 0.02  # the reference itself fits (1.2 % when this test was written)
    assert rep.rel_rms_error <= 1.1 * ref, rep.order_reason


def _auto_fit_and_skrf(name: str) -> tuple[float, float]:
    """Relative RMS errors of vfmodel's default S fit (``delay="auto"``) of scikit-rf's
    file ``name`` and of scikit-rf's ``auto_fit`` of it."""
    data = read_spectrum(SKRF_DATA / name).to_kind("S")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, rep = vector_fit(data, delay="auto")
    return rep.rel_rms_error, _skrf_auto_fit_error(name, data)


def test_plateau_pick_of_fewer_poles_is_converged_first() -> None:
    # wr2p2,line1.s2p (noise-free, 101 points): the growth plateaus at the best error of
    # unconverged steps (~2.9e-6) and the smallest order within 1.25x of it was kept, 8
    # poles at 2.2e-6; relocated to convergence, the pick beats that plateau by more than
    # the margin and becomes the floor: 9 poles at 9.0e-7 (Haswell, Prescott and
    # Sandybridge kernels). Reference: scikit-rf's auto_fit on the same file (8.2e-7),
    # within the order rule's own margin (1.25x of the floor it reaches).
    err, ref = _auto_fit_and_skrf("wr2p2,line1.s2p")
    assert err <= 1.25 * ref


def test_lighter_fit_not_taken_when_it_leaves_the_data_size() -> None:
    # coaxial.s2p: relocated with lighter anchors the model reaches a gain of ~2.5 out of
    # band (data <= 0.9986); the model returned keeps the anchored fit's gain at 0 Hz,
    # 100 f_max and of D (reference: the fit with the anchors' weight given explicitly)
    data = read_spectrum(VFBENCH / "coaxial.s2p").to_kind("S")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model, _ = vector_fit(data, delay="auto")
        anchored, _ = vector_fit(data, delay="auto", out_of_band_weight=1e-4)

    def gain(m: RationalModel) -> float:
        h = m(np.array([0.0, 100.0 * data.freq_hz[-1]]))
        return max(float(np.max(np.linalg.svd(h, compute_uv=False))),
                   float(np.linalg.svd(m.dd, compute_uv=False)[0]))

    assert gain(model) <= max(gain(anchored), 1.0) + 1e-3


def test_values_whose_squares_overflow_are_refused(tmp_path: Path) -> None:
    # a Touchstone file of 1e300 values ended in an internal error in fit (LinAlgError in
    # the relocation's Gram matrix) and info printed norms of inf: FrequencyData refuses
    # magnitudes above 1e100, so every reader and every command does; 1e90 still fits
    f = np.geomspace(1e9, 4e9, 5)
    with pytest.raises(InputError, match="too large"):
        FrequencyData(f, np.array([1e300, -1e300 + 1e300j, 1e300, 5e299, 3e299]), kind="S")
    path = tmp_path / "huge.s1p"
    path.write_text("# GHz S RI R 50\n1 1e300 0\n2 -1e300 1e300\n3 1e300 0\n4 0.5e300 0\n")
    with pytest.raises(InputError, match="too large"):
        read_spectrum(path)
    assert cli_main(["fit", str(path), "--out", str(tmp_path / "out")]) == 2
    assert not (tmp_path / "out" / "model.json").exists()
    assert cli_main(["info", str(path), "--json"]) == 2
    big = FrequencyData(f, cast(NDArray[np.complex128],
                               1e90 * np.array([1.0, -1 + 1j, 1.0, 0.5, 0.3 + 0.1j])), kind="Z")
    model, _ = vector_fit(big)
    assert np.all(np.isfinite(model(f)))


def test_lighter_fit_keeps_the_poles_the_anchors_cannot_judge() -> None:
    # wr1p5,line.s2p (simulated waveguide line, noise-free): below the anchors' cap the
    # one-pole-less trials judged 10 poles as good as 13 (anchored errors near 2e-7); the
    # lighter relocation of the 13 reaches 1.3e-9. Reference: scikit-rf's auto_fit on the
    # same file (8.8e-6); the fit must be 100x better (before: 2.1e-7, 41x)
    err, ref = _auto_fit_and_skrf("wr1p5,line.s2p")
    assert err <= 0.01 * ref
