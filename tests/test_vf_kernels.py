"""The cached and LAPACK-direct kernels of vector fitting against their plain numpy
forms (the reference: the same algebra written out with numpy.linalg)."""

from __future__ import annotations

from typing import cast

import numpy as np
from numpy.typing import NDArray

from vfmodel.fitting import _relocate
from vfmodel.fitting import _vf_core as core


def _problem(anchors: bool = True) -> tuple[core.Problem, np.ndarray]:
    rng = np.random.default_rng(7)
    k, m = 60, 4
    s = cast(NDArray[np.complex128], 1j * np.linspace(0.02, 1.0, k))
    h = rng.standard_normal((k, m)) + 1j * rng.standard_normal((k, m))
    w = np.ones((k, 1))
    anc = None
    if anchors:
        s_v = 1j * np.array([0.01, 0.005, 2.0, 5.0])
        anc = (s_v, np.repeat(h[:1], 4, axis=0), 1e-4)
    prob = core.Problem(s, h, w, True, False, None, ridge=1e-7, anchors=anc)
    reps = core.starting_poles(7, 0.02, 1.0, "log")
    return prob, reps


def test_bases_cache_matches_direct_partial_fractions() -> None:
    prob, reps = _problem()
    pf, basis, basis_v = core.bases(prob, reps)
    assert np.array_equal(pf, core.partial_fractions(prob.s, reps))
    assert np.array_equal(basis[:, -1], np.ones(prob.n_freq))
    assert prob.anchors is not None and basis_v is not None
    assert np.array_equal(basis_v[:, :-1], core.partial_fractions(prob.anchors[0], reps))
    assert core.bases(prob, reps)[0] is pf  # kept


def test_residue_rows_written_in_place_equal_the_stacked_form() -> None:
    prob, reps = _problem()
    sys_ = core._residue_system(prob, reps, None)
    basis = core.full_basis(prob, reps)
    assert prob.anchors is not None
    s_v, h_v, wgt = prob.anchors
    basis_v = np.concatenate([core.partial_fractions(s_v, reps), np.ones((s_v.size, 1))], 1)
    w2 = np.concatenate([prob.w, prob.w])
    a_ref = np.vstack([core._realify(basis) * w2, wgt * core._realify(basis_v)])
    b_ref = np.vstack([core._realify(prob.h) * w2, wgt * core._realify(h_v)])
    assert np.array_equal(sys_.a, a_ref)
    assert np.array_equal(sys_.b, b_ref)


def test_scaled_lstsq_with_ridge_equals_numpy_lstsq() -> None:
    rng = np.random.default_rng(3)
    a = rng.standard_normal((50, 6)) * np.array([1, 10, 1e3, 1e-2, 5, 1])
    b = rng.standard_normal((50, 3))
    ridge = 1e-3
    norms = np.linalg.norm(a, axis=0)
    mu = ridge * np.linalg.norm(b) / np.sqrt(6)
    x_ref = np.linalg.lstsq(np.vstack([a / norms, mu * np.eye(6)]),
                            np.vstack([b, np.zeros((6, 3))]), rcond=None)[0] / norms[:, None]
    x = core._scaled_lstsq(a, b, ridge)
    assert np.max(np.abs(x - x_ref)) < 1e-12 * np.max(np.abs(x_ref))


def test_removal_costs_equal_refits_without_each_pole() -> None:
    # reference: the increase of the squared residual when a representative is removed
    # and the residues are solved again (no ridge: the plain least-squares statistic)
    prob, reps = _problem(anchors=False)
    prob = core.Problem(prob.s, prob.h, prob.w, True, False, None)
    sse = core.weighted_rel_rms(prob, core.evaluate(prob, core.solve_residues(prob, reps)))
    den2 = float(np.linalg.norm(prob.wh)) ** 2
    cost = core.removal_costs(prob, reps)
    for j in range(reps.size):
        rest = np.delete(reps, j)
        e = core.weighted_rel_rms(prob, core.evaluate(prob, core.solve_residues(prob, rest)))
        ref = (e**2 - sse**2) * den2
        assert abs(cost[j] - ref) <= 1e-8 * max(ref, 1e-12 * den2)


def test_state_form_matches_the_real_block_form() -> None:
    reps = core.sort_reps(np.array([-0.3, -0.05 + 0.4j, -2.0, -0.1 + 1.5j]))
    a, b = _relocate._state_form(reps, 2)
    ref = np.zeros((6, 6))
    ref[0, 0], ref[1, 1] = reps[0].real, reps[1].real
    for i, p in zip((2, 4), reps[2:], strict=True):
        ref[i, i] = ref[i + 1, i + 1] = p.real
        ref[i, i + 1], ref[i + 1, i] = p.imag, -p.imag
    assert np.array_equal(a, ref)
    assert np.array_equal(b, [1, 1, 2, 0, 2, 0])
    # eigenvalues of the block form are the poles with their conjugates
    z = np.sort_complex(np.linalg.eigvals(a))
    assert np.allclose(z, np.sort_complex(np.concatenate([reps, reps[2:].conj()])),
                       atol=1e-14)


def _reps_complex(z: NDArray[np.complex128], stable: bool) -> NDArray[np.complex128]:
    """The representatives by complex arithmetic (the formula before reps_from_parts)."""
    im = z.imag
    is_real = np.abs(im) <= 1e-12 * np.maximum(np.abs(z), 1e-300)
    real = z.real[is_real]
    cplx = z[~is_real & (im > 0)]
    if stable:
        real = -np.maximum(np.abs(real), 1e-12)
        cplx = -np.maximum(np.abs(cplx.real), 1e-9 * np.abs(cplx)) + 1j * cplx.imag
    return np.concatenate([np.sort(real)[::-1] + 0j, cplx[np.argsort(cplx.imag)]])


def test_reps_from_parts_equals_the_complex_path() -> None:
    # the relocation takes geev's (wr, wi) directly; it must give exactly what complex
    # arithmetic on the eigenvalues gives (the automatic order follows the last bit)
    from vfmodel.fitting._vf_core import reps_from_parts

    rng = np.random.default_rng(11)
    for _ in range(300):
        n = int(rng.integers(1, 25))
        w = np.linalg.eigvals(rng.normal(size=(n, n)) * rng.uniform(1e-3, 1e3)).astype(complex)
        wr, wi = np.array(w.real, dtype=float), np.array(w.imag, dtype=float)
        for stable in (True, False):
            a = _reps_complex(w, stable)
            b = reps_from_parts(wr.copy(), wi.copy(), stable)
            assert a.shape == b.shape
            assert np.array_equal(a.real, b.real) and np.array_equal(a.imag, b.imag)


def test_gufunc_wrappers_equal_numpy_linalg() -> None:
    # eigh, lstsq and singular values called without numpy.linalg's wrappers must give
    # numpy.linalg's results to the last bit (the automatic order follows rounding), and
    # a LAPACK failure must still raise LinAlgError
    import pytest

    rng = np.random.default_rng(4)
    a = rng.normal(size=(9, 9))
    sym = a + a.T
    lam, vec = core._eigh(sym)
    ref_lam, ref_vec = np.linalg.eigh(sym)
    assert np.array_equal(lam, ref_lam) and np.array_equal(vec, ref_vec)
    tall = rng.normal(size=(12, 7))
    tall[:, 6] = tall[:, 5]  # rank deficient: the minimum-norm solution
    for rhs in (rng.normal(size=12), rng.normal(size=(12, 3))):
        assert np.array_equal(core._lstsq(tall, rhs),
                              np.linalg.lstsq(tall, rhs, rcond=None)[0])
    stack = rng.normal(size=(5, 2, 2)) + 1j * rng.normal(size=(5, 2, 2))
    assert np.array_equal(core.singular_values(stack), np.linalg.svd(stack, compute_uv=False))
    with pytest.raises(np.linalg.LinAlgError):
        core._eigh(np.full((3, 3), np.nan))
