"""Automatic order selection: noise floor, exact models, motor-like impedance."""

from __future__ import annotations

import numpy as np

from tests._motor_like import FREQ_HI_HZ, FREQ_LO_HZ, motor_like_impedance
from tests._vf_models import known_model, relative_pole_error
from vfmodel import FrequencyData, vector_fit

NOISE = 0.005  # 0.5 % complex noise (RMS of |noise| / |Z|)


def _noisy_case(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    truth = known_model(1, 2, 5, seed=21, with_e=False)  # order 12
    f = np.geomspace(1e3, 1e7, 400)
    z = truth(f)[:, 0, 0]
    rng = np.random.default_rng(seed)
    noise = NOISE * np.abs(z) * (rng.normal(size=f.size) + 1j * rng.normal(size=f.size))
    return f, z, z + noise / np.sqrt(2), truth.n_poles


def test_noisy_one_port_order_and_error() -> None:
    f, z, noisy, n_true = _noisy_case(seed=1)
    model, report = vector_fit(FrequencyData(f, noisy, kind="Z"), "auto", weighting="inv_abs")
    # reference: the true order 12, within +-2
    assert abs(report.order - n_true) <= 2, report.order_reason
    # error against the noise-free truth below the noise level (0.5 % RMS relative)
    err_truth = np.sqrt(np.mean(np.abs((model(f)[:, 0, 0] - z) / z) ** 2))
    assert err_truth < NOISE
    # the noise floor estimate is within 30 % of the true 0.5 % (weighted units)
    assert report.noise_floor is not None
    assert abs(report.noise_floor - NOISE) < 0.3 * NOISE
    assert "noise floor" in report.order_reason


def test_noisy_one_port_other_seed() -> None:
    f, z, noisy, n_true = _noisy_case(seed=2)
    model, report = vector_fit(FrequencyData(f, noisy, kind="Z"), "auto", weighting="inv_abs")
    assert abs(report.order - n_true) <= 2, report.order_reason
    err_truth = np.sqrt(np.mean(np.abs((model(f)[:, 0, 0] - z) / z) ** 2))
    assert err_truth < NOISE


def test_clean_multiport_auto_is_exact() -> None:
    truth = known_model(4, 1, 4, seed=5)
    f = np.geomspace(1e3, 1e7, 200)
    model, report = vector_fit(FrequencyData(f, truth(f), kind="Z"), "auto", fit_e=True)
    # reference: the analytic 4-port, order 9 and poles to 1e-8
    assert report.order == truth.n_poles, report.order_reason
    assert relative_pole_error(model.poles, truth.poles) < 1e-8
    assert report.rel_rms_error < 1e-9
    assert report.n_iterations < 50


def test_motor_like_impedance_auto_in_z() -> None:
    f = np.geomspace(FREQ_LO_HZ, FREQ_HI_HZ, 500)
    z = motor_like_impedance(f)
    assert np.abs(z).max() / np.abs(z).min() > 1e4  # 4 decades of |Z|
    model, report = vector_fit(
        FrequencyData(f, z, kind="Z"), "auto", weighting="inv_abs", fit_e=True
    )
    mape = 100 * np.mean(np.abs(np.abs(model(f)[:, 0, 0]) - np.abs(z)) / np.abs(z))
    # reference: the analytic ladder, |Z| MAPE below 0.5 %
    assert mape < 0.5, (mape, report.order_reason)
    assert model.kind == "Z" and model.is_stable
    assert report.order <= 24


def test_order_growth_ends_when_pruning_takes_back_new_poles() -> None:
    """data/regression/independent102_V-W.csv: the automatic order never returned (each
    step's new poles were pruned again and the plateau test never fired)."""
    import signal
    from pathlib import Path

    from vfmodel.core.io_spectrum import read_spectrum

    path = Path(__file__).resolve().parents[1] / "data/regression/independent102_V-W.csv"
    data = read_spectrum(path)

    def stuck(*_: object) -> None:
        raise TimeoutError("the automatic order did not return within 60 s (0.1 s expected)")

    old = signal.signal(signal.SIGALRM, stuck)
    signal.alarm(60)
    try:
        _, report = vector_fit(data, "auto")
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    # reference: the generator's noise, 0.622 % of |Z| per point (truth.json z_noise);
    # a fit at the noise floor has about that per-point RMS error, and not 1.25x more
    assert report.point_rel_rms_error is not None
    assert report.point_rel_rms_error < 1.25 * 0.00622, report.order_reason
    assert report.order <= 20, report.order_reason
