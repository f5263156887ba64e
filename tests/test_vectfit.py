"""Vector fitting with a fixed order: exact recovery of known rational models, state
space, 0 Hz handling, stability, input forms and degenerate input."""

from __future__ import annotations

import numpy as np
import pytest
import skrf

from benches.skrf_reference import skrf_response
from tests._motor_like import FREQ_HI_HZ, FREQ_LO_HZ, motor_like_impedance
from tests._vf_models import known_model, relative_pole_error
from vfmodel import FrequencyData, RationalModel, vector_fit
from vfmodel.errors import InputError

FREQ = np.geomspace(1e3, 1e7, 240)


@pytest.mark.parametrize(
    ("n_ports", "n_real", "n_pairs"),
    [(1, 2, 3), (2, 1, 4), (3, 2, 2), (4, 1, 3), (6, 2, 3)],
)
def test_known_model_poles_recovered(n_ports: int, n_real: int, n_pairs: int) -> None:
    truth = known_model(n_ports, n_real, n_pairs, seed=n_ports)
    data = FrequencyData(FREQ, truth(FREQ), kind="Z")
    model, report = vector_fit(data, truth.n_poles, fit_e=True)
    # reference: the analytic model; tolerance 1e-8 relative on every pole
    assert relative_pole_error(model.poles, truth.poles) < 1e-8
    assert report.rel_rms_error < 1e-9
    assert np.allclose(model.dd, truth.dd, rtol=1e-6, atol=1e-6 * np.abs(truth.dd).max())
    assert np.allclose(model.ee, truth.ee, rtol=1e-6, atol=1e-6 * np.abs(truth.ee).max())
    # the convergence test stops early on clean data
    assert report.converged and report.n_iterations <= 10
    assert report.order == truth.n_poles


def test_state_space_matches_pole_residue() -> None:
    truth = known_model(3, 2, 3, seed=7)
    data = FrequencyData(FREQ, truth(FREQ), kind="Z")
    model, _ = vector_fit(data, truth.n_poles, fit_e=True)
    ss = model.to_state_space()
    s = 2j * np.pi * FREQ
    eye = np.eye(ss.a.shape[0])
    h_ss = np.stack(
        [ss.c @ np.linalg.solve(si * eye - ss.a, ss.b) + ss.d + si * ss.e for si in s]
    )
    h_pr = model(FREQ)
    # reference: the pole-residue evaluation, 1e-10 relative
    assert np.linalg.norm(h_ss - h_pr) / np.linalg.norm(h_pr) < 1e-10
    assert np.all(np.isreal(ss.a)) and ss.a.dtype == np.float64


def test_network_input_and_kind_conversion() -> None:
    truth = known_model(2, 1, 2, seed=3, kind="Z", with_e=False)
    zdata = FrequencyData(FREQ, truth(FREQ), kind="Z")
    net = zdata.to_network(z0=50.0)
    # S of a 2-port Z model with full-rank residues has twice as many poles (McMillan degree)
    m_s, _ = vector_fit(net, 2 * truth.n_poles)  # S by default for a Network
    assert m_s.kind == "S" and m_s.z0 == 50.0
    s_ref = zdata.to_kind("S", 50.0).values
    # reference: the analytic Z converted to S
    assert np.linalg.norm(m_s(FREQ) - s_ref) / np.linalg.norm(s_ref) < 1e-8
    m_z, _ = vector_fit(net, truth.n_poles, kind="Z")
    assert m_z.kind == "Z"
    assert relative_pole_error(m_z.poles, truth.poles) < 1e-8


def test_dc_point_is_matched_exactly() -> None:
    rng = np.random.default_rng(5)
    truth = known_model(2, 1, 2, seed=11, with_e=False)
    f = np.concatenate([[0.0], np.geomspace(1e3, 1e7, 120)])
    h = truth(f)
    noisy = h * (1 + 0.01 * (rng.normal(size=h.shape) + 1j * rng.normal(size=h.shape)))
    noisy[0] = noisy[0].real
    model, report = vector_fit(FrequencyData(f, noisy, kind="Z"), truth.n_poles)
    # reference: the data's own 0 Hz value, matched to 1e-10 relative
    h0 = model(0.0)[0]
    assert np.max(np.abs(h0 - noisy[0].real)) < 1e-10 * np.max(np.abs(noisy[0]))
    assert report.rel_rms_error < 0.02


def test_unstable_poles_are_flipped() -> None:
    # data of a model with an unstable pair: the fit must still be stable
    p = 2 * np.pi * np.array([2e5 + 1e6j, 2e5 - 1e6j, -3e4])
    r = np.array([1e6 + 2e5j, 1e6 - 2e5j, 5e4]).reshape(3, 1, 1)
    unstable = RationalModel(poles=p, residues=r, d=[[1.0]], kind="H")
    data = FrequencyData(FREQ, unstable(FREQ), kind="H")
    model, _ = vector_fit(data, 3)
    assert model.is_stable and np.all(model.poles.real < 0)
    # without flipping the same fit recovers the unstable truth (reference: its poles, 1e-8)
    free, _ = vector_fit(data, 3, enforce_stability=False)
    assert relative_pole_error(free.poles, unstable.poles) < 1e-8


def test_motor_like_impedance_fixed_order_in_z() -> None:
    f = np.geomspace(FREQ_LO_HZ, FREQ_HI_HZ, 400)
    z = motor_like_impedance(f)
    model, report = vector_fit(
        FrequencyData(f, z, kind="Z"), 12, weighting="inv_abs", fit_e=True
    )
    mape = 100 * np.mean(np.abs(np.abs(model(f)[:, 0, 0]) - np.abs(z)) / np.abs(z))
    # reference: the analytic ladder; CONTRACT MAPE below 0.5 %
    assert mape < 0.5
    assert report.kind == "Z"


@pytest.mark.parametrize("weighting", ["uniform", "inv_abs", "inv_sqrt_abs", "array"])
def test_weightings_recover_exact_model(weighting: str) -> None:
    truth = known_model(2, 1, 3, seed=2)
    data = FrequencyData(FREQ, truth(FREQ), kind="Z")
    w = np.geomspace(1.0, 10.0, FREQ.size) if weighting == "array" else weighting
    model, _ = vector_fit(data, truth.n_poles, weighting=w, fit_e=True)
    assert relative_pole_error(model.poles, truth.poles) < 1e-8


def test_linear_starting_poles() -> None:
    truth = known_model(1, 0, 4, seed=4, with_e=False)
    f = np.linspace(1e3, 1e7, 300)
    model, _ = vector_fit(FrequencyData(f, truth(f), kind="Z"), 8, spacing="lin")
    assert relative_pole_error(model.poles, truth.poles) < 1e-8


def test_matches_scikit_rf_on_same_order() -> None:
    # reference: scikit-rf's VectorFitting at the same number of poles (2 real + 4 pairs)
    truth = known_model(2, 2, 4, seed=9, with_e=False)
    data = FrequencyData(FREQ, truth(FREQ), kind="Z").to_kind("S", 50.0)
    net = data.to_network()
    vf = skrf.vectorFitting.VectorFitting(net)
    vf.vector_fit(n_poles_real=2, n_poles_cmplx=4, init_pole_spacing="log")
    s_skrf = skrf_response(vf, FREQ)
    err_skrf = np.linalg.norm(s_skrf - data.values) / np.linalg.norm(data.values)
    _, report = vector_fit(data, 10)
    assert report.rel_rms_error <= max(err_skrf, 1e-12)


# ---------------------------------------------------------------------- degenerate input
def test_fewer_points_than_poles() -> None:
    f = np.geomspace(1e3, 1e6, 5)
    data = FrequencyData(f, 1 / (1 + 1j * f / 1e4), kind="H")
    with pytest.raises(InputError, match="order 20 needs more frequency points"):
        vector_fit(data, 20)


def test_constant_data() -> None:
    # a frequency-independent response is a legitimate model: no poles, D alone
    data = FrequencyData(FREQ, np.full(FREQ.size, 3.0 + 0j), kind="Z")
    for order in (4, "auto"):
        model, report = vector_fit(data, order)
        assert model.n_poles == 0 and report.order == 0
        assert model.d[0, 0] == pytest.approx(3.0, rel=1e-12)
        assert report.rel_rms_error < 1e-12


def test_all_zero_data() -> None:
    data = FrequencyData(FREQ, np.zeros((FREQ.size, 2, 2)), kind="Z")
    model, report = vector_fit(data, 4)
    assert model.n_poles == 0 and np.all(model.d == 0) and report.rms_error == 0


def test_constant_complex_data_refused() -> None:
    data = FrequencyData(FREQ, np.full(FREQ.size, 3.0 + 1j), kind="Z")
    with pytest.raises(InputError, match="constant that is not real"):
        vector_fit(data, 4)


def test_single_frequency() -> None:
    data = FrequencyData([1e6], [[[1.0 + 1j]]], kind="Z")
    with pytest.raises(InputError, match="too few frequency points"):
        vector_fit(data, "auto")


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"order": 0}, "order must be at least 1"),
        ({"order": "six"}, "order must be a positive integer"),
        ({"order": 4, "weighting": "bad"}, "weighting"),
        ({"order": 4, "weighting": np.ones(3)}, "weighting array has the wrong shape"),
        ({"order": 4, "spacing": "cubic"}, "spacing"),
        ({"order": 4, "max_iterations": 0}, "max_iterations"),
    ],
)
def test_bad_arguments(kwargs: dict[str, object], match: str) -> None:
    data = FrequencyData(FREQ, 1 / (1 + 1j * FREQ / 1e5), kind="H")
    with pytest.raises(InputError, match=match):
        vector_fit(data, **kwargs)


def test_not_frequency_data() -> None:
    with pytest.raises(InputError, match=r"FrequencyData, a skrf\.Network or a path"):
        vector_fit(np.ones(10), 2)
