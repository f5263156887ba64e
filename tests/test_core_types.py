"""Core types: FrequencyData conversions against scikit-rf, RationalModel realisation."""

from __future__ import annotations

from typing import cast

import numpy as np
import pytest
import skrf
from numpy.typing import NDArray

from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import InputError


def _random_z(n: int, n_f: int = 7, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n_f, n, n)) + 1j * rng.normal(size=(n_f, n, n))
    return a + np.swapaxes(a, 1, 2) + 4 * n * np.eye(n)


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_conversions_match_scikit_rf(n: int) -> None:
    z = _random_z(n)
    d = FrequencyData(cast(NDArray[np.float64], np.arange(1, 8) * 1e6), z, "Z")
    # reference: scikit-rf's own conversion formulas at z0 = 50 ohm
    s_ref = skrf.network.z2s(z, 50.0)
    y_ref = skrf.network.z2y(z)
    assert np.max(np.abs(d.to_kind("S").values - s_ref)) < 1e-12
    assert np.max(np.abs(d.to_kind("Y").values - y_ref)) < 1e-12 * np.max(np.abs(y_ref))
    # round trips Z -> S -> Y -> Z
    back = d.to_kind("S", z0=75.0).to_kind("Y").to_kind("Z")
    assert np.max(np.abs(back.values - z)) / np.max(np.abs(z)) < 1e-12


def test_network_round_trip() -> None:
    z = _random_z(3)
    d = FrequencyData(cast(NDArray[np.float64], np.arange(1, 8) * 1e6), z, "Z")
    net = d.to_network(z0=50.0)
    assert np.max(np.abs(net.z - z)) / np.max(np.abs(z)) < 1e-12
    back = FrequencyData.from_network(net, kind="Z")
    assert np.max(np.abs(back.values - z)) / np.max(np.abs(z)) < 1e-12


@pytest.mark.parametrize(
    ("freq", "values", "msg"),
    [
        ([1.0, 1.0, 2.0], [1, 2, 3], "duplicate frequency"),
        ([1.0, 3.0, 2.0], [1, 2, 3], "decreasing frequency"),
        ([1.0, np.nan, 2.0], [1, 2, 3], "not finite"),
        ([1.0, 2.0, 3.0], [1, np.inf, 3], "NaN or infinite"),
        ([-1.0, 2.0, 3.0], [1, 2, 3], "negative frequency"),
        ([1.0, 2.0], [1, 2, 3], "shape"),
    ],
)
def test_frequency_data_rejects(freq: list[float], values: list[complex], msg: str) -> None:
    with pytest.raises(InputError, match=msg):
        FrequencyData(np.array(freq), np.array(values, dtype=complex), "Z", source="x.csv")


def test_state_space_matches_pole_residue() -> None:
    rng = np.random.default_rng(3)
    n_out, n_in = 3, 2
    p = np.array([-1e3, -5e4 + 2e5j, -5e4 - 2e5j, -1e6 + 3e6j, -1e6 - 3e6j])
    r = rng.normal(size=(5, n_out, n_in)) + 1j * rng.normal(size=(5, n_out, n_in))
    r[0] = r[0].real
    r[2], r[4] = np.conj(r[1]), np.conj(r[3])
    m = RationalModel(p, r, d=rng.normal(size=(n_out, n_in)), e=1e-7 * np.ones((n_out, n_in)),
                      kind="H")
    ss = m.to_state_space()
    s = 2j * np.pi * np.logspace(1, 7, 25)
    eye = np.eye(ss.a.shape[0])
    h_ss = np.array([ss.c @ np.linalg.solve(si * eye - ss.a, ss.b) + ss.d + si * ss.e for si in s])
    h = m.evaluate_s(s)
    assert np.max(np.abs(h_ss - h)) / np.max(np.abs(h)) < 1e-12
    assert np.all(np.isreal(ss.a)) and ss.a.shape == (10, 10)


def test_rational_model_requires_conjugate_pairs() -> None:
    with pytest.raises(InputError, match="without its conjugate"):
        RationalModel(np.array([-1 + 2j]), np.array([1.0 + 0j]))
    with pytest.raises(InputError, match="not conjugate"):
        RationalModel(np.array([-1 + 2j, -1 - 2j]), np.array([1 + 1j, 2 - 1j]))


def test_rational_model_canonical_input_same_as_reordered() -> None:
    # a fit's model arrives in canonical order and skips the pair search; the result must
    # be the one the search gives for the same poles listed in any order (conjugates to
    # within 1e-12 made exact), and a non-conjugate residue must still be refused
    rng = np.random.default_rng(5)
    p = np.array([-3.0, -0.2 + 4j, -0.2 - 4j + 1e-12, -1 + 9j, -1 - 9j])
    r = rng.normal(size=(5, 2, 2)) + 1j * rng.normal(size=(5, 2, 2))
    r[0] = r[0].real
    r[2], r[4] = np.conj(r[1]), np.conj(r[3])
    canonical = RationalModel(p, r, kind="H")
    perm = np.array([2, 0, 4, 1, 3])  # the upper poles keep their relative order
    searched = RationalModel(p[perm], r[perm], kind="H")
    assert np.array_equal(canonical.poles, searched.poles)
    assert np.array_equal(canonical.residues, searched.residues)
    assert canonical.poles[2] == np.conj(canonical.poles[1])  # made exact
    bad = r.copy()
    bad[2] = bad[2] + 1e-3
    with pytest.raises(InputError, match="not conjugate"):
        RationalModel(p, bad, kind="H")


def test_rational_model_json_round_trip() -> None:
    m = RationalModel(np.array([-2.0, -1 + 5j, -1 - 5j]), np.array([1.0, 2 + 1j, 2 - 1j]),
                      d=[[0.5]], e=[[1e-9]], kind="Z")  # type: ignore[arg-type]
    back = RationalModel.from_json_dict(m.to_json_dict())
    f = np.logspace(-1, 1, 9)
    assert np.max(np.abs(back(f) - m(f))) == 0.0
