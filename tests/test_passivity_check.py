"""Passivity test: Hamiltonian band edges against analytic values and dense sampling."""

from __future__ import annotations

import numpy as np
import pytest

from tests._random_models import (
    TWO_PI,
    random_nonpassive,
    ref_crossings,
    ref_grid,
    ref_margin,
)
from vfmodel import RationalModel, check_passivity
from vfmodel.errors import InputError


def _cases() -> list[tuple[str, int, bool]]:
    """30 models: Z, Y, S x 1-4 ports, every fifth with singular D + D^T (resp. sigma(D)=1)."""
    return [("ZYS"[i % 3], 1 + (i // 3) % 4, i % 5 == 4) for i in range(30)]


def test_band_edges_match_dense_sampling_30_models() -> None:
    # reference: 1e5-point log grid (+ points at every resonance), sign changes of
    # min eig Re H (Z, Y) resp. 1 - sigma_max (S) refined with brentq
    rng = np.random.default_rng(2024)
    forms = []
    n_edges = 0
    for kind, n, singular in _cases():
        model = random_nonpassive(rng, kind, n, singular_d=singular)
        report = check_passivity(model)
        assert report.method == "hamiltonian"
        assert not report.passive
        ref_hz = ref_crossings(model) / TWO_PI
        got = np.array(report.crossings_hz)
        # every finite band edge is a crossing of the reference and vice versa
        assert got.size == ref_hz.size, (kind, n, singular, got, ref_hz)
        if got.size:
            assert np.max(np.abs(got - ref_hz) / ref_hz) < 1e-6
        n_edges += got.size
        forms.append(report.hamiltonian_form)
        # bands are where the reference margin is negative: check each band's midpoint
        for lo, hi in report.bands_hz:
            if lo > 0:
                mid = np.sqrt(lo * hi) if np.isfinite(hi) else 2 * lo
            else:
                mid = hi / 2 if np.isfinite(hi) else 1e5
            assert ref_margin(model, np.array([TWO_PI * mid]))[0] < 0
    assert n_edges >= 60
    assert "pencil" in forms and "standard" in forms


def test_analytic_crossing_one_port_z() -> None:
    # Z = d + r/(s + a), r < 0: Re Z(jw) = d + r a / (w^2 + a^2) < 0 for w < w_c with
    # w_c = sqrt(-r a / d - a^2)
    a, r, d = 2 * np.pi * 1e5, -3.0 * 2 * np.pi * 1e5, 1.0
    model = RationalModel(poles=[-a], residues=[r], d=[[d]], kind="Z")
    wc = np.sqrt(-r * a / d - a**2)
    for method in ("hamiltonian", "sampling"):
        rep = check_passivity(model, method=method)
        assert rep.method == method
        assert len(rep.bands_hz) == 1
        lo, hi = rep.bands_hz[0]
        assert lo == 0.0
        assert abs(hi - wc / TWO_PI) / (wc / TWO_PI) < 1e-9
        # worst violation at w = 0: -(d + r/a) = 2
        assert abs(rep.worst_violation - 2.0) < 1e-9
        assert rep.worst_freq_hz is not None and rep.worst_freq_hz < 1e-3 * hi


def test_passive_rc_impedance_with_zero_d_uses_pencil() -> None:
    # parallel RC: Z = (1/C) / (s + 1/RC), positive real, D = 0 (singular D + D^T)
    r_ohm, c_f = 50.0, 1e-9
    model = RationalModel(poles=[-1 / (r_ohm * c_f)], residues=[1 / c_f], kind="Z")
    rep = check_passivity(model)
    assert rep.passive and rep.stable and rep.asymptotic_ok
    assert rep.hamiltonian_form == "pencil"
    assert rep.bands_hz == () and rep.worst_violation == 0.0


def test_asymptotic_conditions() -> None:
    p, r = [-1e6], [1e6]
    # D + D^T not PSD: violation band reaching infinity
    z = RationalModel(poles=p, residues=r, d=[[-0.5]], kind="Z")
    rep = check_passivity(z)
    assert not rep.asymptotic_ok and rep.d_margin == -0.5
    assert rep.bands_hz[-1][1] == np.inf
    # Re Z = -0.5 + 1e12/(w^2 + 1e12) -> crossing at w = 1e6 rad/s
    assert abs(rep.bands_hz[-1][0] - 1e6 / TWO_PI) / (1e6 / TWO_PI) < 1e-9
    # S with sigma_max(D) = 1.2
    s = RationalModel(poles=p, residues=[1e5], d=[[1.2]], kind="S")
    rep = check_passivity(s)
    assert not rep.passive and abs(rep.d_margin + 0.2) < 1e-12
    assert rep.worst_violation >= 0.2 - 1e-12
    # non-symmetric E of a 2-port Z
    e = np.array([[1e-6, 1e-6], [0.0, 1e-6]])
    z2 = RationalModel(
        poles=p, residues=np.eye(2)[None] * 1e6, d=np.eye(2), e=e, kind="Z"
    )
    rep = check_passivity(z2)
    assert not rep.e_ok and not rep.passive


def test_unstable_and_wrong_kind() -> None:
    unstable = RationalModel(poles=[1e3], residues=[1.0], d=[[1.0]], kind="Z")
    rep = check_passivity(unstable)
    assert not rep.stable and not rep.passive
    with pytest.raises(InputError, match="Z, Y and S"):
        check_passivity(RationalModel(poles=[-1.0], residues=[1.0], kind="H"))


def test_sampling_method_and_worst_violation_agree_with_reference() -> None:
    rng = np.random.default_rng(7)
    for kind, n in (("Z", 2), ("Y", 3), ("S", 4)):
        model = random_nonpassive(rng, kind, n)
        ham = check_passivity(model)
        smp = check_passivity(model, method="sampling")
        assert smp.method == "sampling"
        assert len(ham.crossings_hz) == len(smp.crossings_hz)
        np.testing.assert_allclose(smp.crossings_hz, ham.crossings_hz, rtol=1e-6)
        # worst violation: dense reference minimum of the margin
        w = ref_grid(model)
        worst_ref = -ref_margin(model, w).min()
        assert ham.worst_violation >= worst_ref * (1 - 1e-9)
        assert ham.worst_violation <= worst_ref * (1 + 1e-3)


def test_describe_names_an_asymptotic_violation_without_bands() -> None:
    # a lossless 4-port balun fitted to 8e-13 gave sigma_max(D) = 1 + 3.2e-13 and no band;
    # the CLI said "NOT passive (0 violation bands)". Reference: D = 1 + 3e-13 and a pole
    # with zero residue, so sigma_max(H(jw)) = 1 + 3e-13 at every frequency: below the
    # band test's tolerance, caught by the asymptotic condition
    s = RationalModel(poles=[-1e6], residues=[0.0], d=[[1.0 + 3e-13]], kind="S")
    rep = check_passivity(s)
    assert not rep.passive and rep.bands_hz == ()
    text = rep.describe()
    assert "violation band" not in text
    assert "at infinity: sigma_max(D) = 1 + 3" in text and "e-13" in text
    # above the tolerance the same violation is a band from 0 Hz to infinity
    big = check_passivity(RationalModel(poles=[-1e6], residues=[0.0], d=[[1.0 + 1e-7]],
                                        kind="S"))
    assert big.bands_hz == ((0.0, np.inf),)
    assert big.describe().startswith("NOT passive (1 violation band; at infinity")
    # a band: counted, singular
    z = RationalModel(poles=[-2 * np.pi * 1e5], residues=[-3.0 * 2 * np.pi * 1e5], d=[[1.0]],
                      kind="Z")
    assert check_passivity(z).describe().startswith("NOT passive (1 violation band;")
    ok = RationalModel(poles=[-1 / (50.0 * 1e-9)], residues=[1 / 1e-9], kind="Z")
    assert check_passivity(ok).describe() == "passive (certified)"
