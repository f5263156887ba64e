"""Passivity on real data: the two Touchstone files, and a motor-like impedance simulated
in the time domain (the energy it returns never exceeds what it absorbed)."""

from __future__ import annotations

import functools
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

import vfmodel
from vfmodel import FrequencyData, RationalModel, check_passivity, enforce_passivity
from vfmodel.fitting.artifacts import find_artifacts
from vfmodel.fitting.passivity import PassivityReport
from vfmodel.fitting.vectfit import fit_errors

REPO = Path(__file__).resolve().parents[1]
_DIRS = [REPO.parent / "shared" / "data" / "touchstone", REPO / "data" / "touchstone"]
TOUCHSTONE = next((d for d in _DIRS if d.is_dir()), _DIRS[0])


# Both files with the automatic order. The CST file is fitted on its computed band only:
# 40.1-60 MHz repeat the 40 MHz sample bit for bit (export padding) and two isolated
# single-sample spikes (19.9 MHz: sigma_max 1.085; 30 MHz) get zero weight, as the fit job
# does by default (vfmodel.fitting.artifacts). Errors count the spikes.
@functools.cache
def _fit(name: str) -> tuple[FrequencyData, RationalModel, float]:
    skrf = pytest.importorskip("skrf")
    path = TOUCHSTONE / name
    if not path.exists():
        pytest.skip(f"{path} missing")
    data = FrequencyData.from_network(skrf.Network(str(path)), kind="S", source=name)
    art = find_artifacts(data)
    if art.found:
        k = art.n_genuine
        data = FrequencyData(data.freq_hz[:k], data.values[:k], kind="S", z0=data.z0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vfmodel.errors.FitWarning)
        model, report = vfmodel.vector_fit(data, order="auto", exclude=art.spikes or None)
    return data, model, report.rms_error


@functools.cache
def _enforced(name: str) -> tuple[RationalModel, PassivityReport]:
    data, model, _ = _fit(name)
    return enforce_passivity(model, data, weighting="uniform")


_FILES = ["Agilent_E5071B.s4p", "cst_example_4ports.s4p"]


@pytest.mark.parametrize("name", _FILES)
def test_touchstone_fit_made_passive(name: str) -> None:
    data, model, _ = _fit(name)
    before = check_passivity(model)
    assert not before.passive  # the unconstrained fits violate passivity
    fixed, report = _enforced(name)
    # certified by the Hamiltonian test, and confirmed by 1e5-point sampling up to 3x the
    # data's top frequency (sigma_max <= 1 up to rounding)
    assert report.passive and report.method == "hamiltonian" and report.iterations >= 1
    f = np.linspace(0.0, 3 * data.freq_hz[-1], 100_000)
    sv = np.linalg.svd(fixed(f), compute_uv=False)[:, 0]
    assert sv.max() <= 1 + 1e-12


@pytest.mark.parametrize("name", _FILES)
def test_touchstone_rms_within_1_2x(name: str) -> None:
    # issue 4: RMS error after enforcement at most 1.2x the unconstrained fit's
    data, _, rms_fit = _fit(name)
    fixed, _ = _enforced(name)
    rms_after = fit_errors(fixed, data)[0]
    assert rms_after == pytest.approx(
        np.sqrt(np.mean(np.abs(fixed(data.freq_hz) - data.values) ** 2)), rel=1e-12
    )
    assert rms_after <= 1.2 * rms_fit


def test_cst_clean_samples_barely_change() -> None:
    # the CST ratio above is dominated by the spike at 19.9 MHz; on the other samples the
    # enforcement changes the response by less than 1e-4 of its RMS (0.50), i.e. < 5e-5
    data, model, _ = _fit("cst_example_4ports.s4p")
    fixed, _ = _enforced("cst_example_4ports.s4p")
    ok = np.setdiff1d(np.arange(data.n_freq), find_artifacts(data).spikes)
    assert ok.size == data.n_freq - 2
    change = fixed(data.freq_hz[ok]) - model(data.freq_hz[ok])
    assert float(np.sqrt(np.mean(np.abs(change) ** 2))) < 5e-5
    assert np.linalg.norm(fixed.dd, 2) <= 1.0


# ---------------------------------------------------------------------- motor-like Z
def _motor_impedance(f: np.ndarray) -> np.ndarray:
    """Positive-real DM winding impedance: (R0 + s L0 + two parallel RLC tanks) in
    parallel with the winding capacitance Cp; strictly proper (D = 0)."""
    s = 2j * np.pi * f
    z = 0.5 + s * 200e-6
    for r, l_h, c_f in ((200.0, 50e-6, 2e-9), (50.0, 5e-6, 0.5e-9)):
        z = z + 1 / (1 / r + 1 / (s * l_h) + s * c_f)
    return 1 / (s * 200e-12 + 1 / z)


def _absorbed_energy(model: RationalModel, t: np.ndarray, i: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Cumulative int v i dt (J) of the Z model driven by current i (zero initial state)."""
    ss = model.to_state_space()
    assert np.all(ss.e == 0)
    sys_ = signal.StateSpace(ss.a, ss.b, ss.c, ss.d)
    _, v, x = signal.lsim(sys_, i, t)  # exact for piecewise-linear input
    p = v * i
    w = np.concatenate([[0.0], np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(t))])
    return w, x


def test_motor_impedance_positive_real_and_energy_balance() -> None:
    f = np.logspace(3, 7, 400)
    # measurement with a 1.5 ns fixture delay: phase error that pushes Re Z below zero where
    # the winding is almost purely reactive, so the fitted model is not positive real
    z_meas = _motor_impedance(f) * np.exp(2j * np.pi * f * 1.5e-9)
    data = FrequencyData(f, z_meas, kind="Z")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vfmodel.errors.FitWarning)
        model, _ = vfmodel.vector_fit(data, order="auto", weighting="inv_abs")
    before = check_passivity(model)
    assert before.stable and not before.passive
    fixed, report = enforce_passivity(model, data)
    assert report.passive
    assert check_passivity(fixed).passive
    # relative change of the response is small compared with |Z| (RMS, relative weighting)
    assert report.rel_rms_change < 0.05

    # PWM-like current: 20 kHz, 50 % duty, 50 ns edges, 10 periods, then 200 us of zero
    dt = 5e-9
    t = np.arange(0.0, 700e-6, dt)
    period, rise = 50e-6, 50e-9
    ph = np.mod(t, period)
    i = np.clip(np.minimum(ph / rise, (period / 2 - ph) / rise + 1), 0, 1)
    i[t > 10 * period] = 0.0
    w, x = _absorbed_energy(fixed, t, i)
    # passivity: energy returned never exceeds energy absorbed (rounding tolerance 1e-9)
    assert w.min() >= -1e-9 * w.max()
    # no growth: the state decays after the drive stops
    norm = np.linalg.norm(x, axis=1)
    assert norm[-1] < 1e-6 * norm.max()

    # the non-enforced model, driven at its worst violation frequency, returns more energy
    # than it absorbed (the test can fail)
    assert before.worst_freq_hz is not None and np.isfinite(before.worst_freq_hz)
    f0 = before.worst_freq_hz
    t0 = np.arange(0.0, 400 / f0, 1 / (40 * f0))
    i0 = np.sin(2 * np.pi * f0 * t0)
    w_bad, _ = _absorbed_energy(model, t0, i0)
    w_good, _ = _absorbed_energy(fixed, t0, i0)
    assert w_bad[-1] < 0
    assert w_good.min() >= -1e-9 * max(w_good.max(), 1e-300)
