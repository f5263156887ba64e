"""Batched MNA: known circuits (analytic), solvers agree, adjoint sensitivities, poles."""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np
import pytest
from numpy.typing import NDArray

from benches.random_networks import random_rlc_network
from vfmodel.circuit.mna import MnaSystem, SolveMethod
from vfmodel.circuit.netlist import Circuit, Excitation, Probe
from vfmodel.circuit.poles import network_poles
from vfmodel.errors import InputError

F = np.logspace(2, 7, 60)


def test_series_rlc_port_impedance_analytic() -> None:
    r, l_h, c_f = 5.0, 2e-6, 1e-9
    c = (Circuit().add_resistor("R", "a", "b", r).add_inductor("L", "b", "d", l_h)
         .add_capacitor("C", "d", "0", c_f).add_resistor("Rbig", "d", "0", 1e12))
    s = 2j * np.pi * F
    z_ref = r + s * l_h + 1 / (s * c_f + 1e-12)
    z = c.port_impedance(F, [("a", "0")])[:, 0, 0]
    np.testing.assert_allclose(z, z_ref, rtol=1e-11)


def test_mutual_inductance_transformer_analytic() -> None:
    # V1 - R1 - L1 ; L2 - R2 loaded; k couples. I1 = V/(R1 + sL1 - (sM)^2/(R2 + sL2))
    r1, r2, l1, l2, k = 2.0, 50.0, 1e-5, 4e-5, 0.8
    c = (Circuit().add_vsource("V1", "in", "0").add_resistor("R1", "in", "a", r1)
         .add_inductor("L1", "a", "0", l1).add_inductor("L2", "b", "0", l2)
         .add_resistor("R2", "b", "0", r2).add_mutual("K", "L1", "L2", k))
    s = 2j * np.pi * F
    m = k * np.sqrt(l1 * l2)
    i1 = 1 / (r1 + s * l1 - (s * m) ** 2 / (r2 + s * l2))
    i2 = -s * m * i1 / (r2 + s * l2)       # current in L2 from b to 0 (dot at b)
    h = c.transfer(["V1"], ["i(L1)", "i(L2)", "b"])(F)[:, :, 0]
    np.testing.assert_allclose(h[:, 0], i1, rtol=1e-11)
    np.testing.assert_allclose(h[:, 1], i2, rtol=1e-11)
    np.testing.assert_allclose(h[:, 2], -r2 * i2, rtol=1e-11)


def test_controlled_sources_analytic() -> None:
    # VCVS gain 3, VCCS 2 mS into 1k, CCCS x4 of i(V1) into 100 ohm, CCVS 10 ohm * i(V1)
    c = (Circuit().add_vsource("V1", "in", "0").add_resistor("R0", "in", "0", 50.0)
         .add_vcvs("E1", "e", "0", "in", "0", 3.0).add_resistor("Re", "e", "0", 1.0)
         .add_vccs("G1", "0", "g", "in", "0", 2e-3).add_resistor("Rg", "g", "0", 1e3)
         .add_cccs("F1", "0", "f", "V1", 4.0).add_resistor("Rf", "f", "0", 100.0)
         .add_ccvs("H1", "h", "0", "V1", 10.0).add_resistor("Rh", "h", "0", 1.0))
    h = c.ac([1e3], ["e", "g", "f", "h", "i(V1)"])[0]
    i_v1 = -1 / 50.0  # SPICE sign: current into + terminal through the source
    np.testing.assert_allclose(h, [3.0, 2.0, 4 * i_v1 * 100, 10 * i_v1, i_v1], rtol=1e-13)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_dense_sparse_modal_agree(seed: int) -> None:
    c = random_rlc_network(np.random.default_rng(seed), n_elements=40)
    mna = c.mna
    outs = list(c.nodes)
    ref = mna.response(F, ["V1"], outs, method="dense")
    sp_ = mna.response(F, ["V1"], outs, method="sparse")
    mo = mna.response(F, ["V1"], outs, method="modal")
    he = mna.solve(F, mna.input_matrix(["V1"]), mna.output_matrix(outs), method="hessenberg")
    assert he.method == "hessenberg"  # passed its spot check, no fallback
    scale = np.linalg.norm(ref, axis=1, keepdims=True)
    assert np.max(np.abs(sp_ - ref) / scale) < 1e-12
    assert np.max(np.abs(mo - ref) / scale) < 1e-8
    assert np.max(np.abs(he.h - ref) / scale[..., None]) < 1e-10


def _forward_complex_step(mna: MnaSystem, inputs: Sequence[Excitation],
                          outputs: Sequence[Probe], v: np.ndarray) -> np.ndarray:
    """Forward (direct) sensitivities dH = -Cout^T A^-1 (dG + s dC) A^-1 B.

    dG/dp and dC/dp come from complex steps of the real matrices (exact: no subtraction),
    the solves are independent of the adjoint ones.
    """
    g, c = mna.matrices(v)
    b = mna.input_matrix(inputs)
    co = mna.output_matrix(outputs)
    s = 2j * np.pi * F
    a = g[None] + s[:, None, None] * c[None]
    x = np.linalg.solve(a, np.broadcast_to(b, (F.size, *b.shape)))
    jac = []
    for p in range(v.size):
        h = 1e-30 * abs(v[p])
        vc = v.astype(complex)
        vc[p] += 1j * h
        gc, cc = mna.matrices(vc)
        da = (gc.imag[None] + s[:, None, None] * cc.imag[None]) / h
        dx = -np.linalg.solve(a, da @ x)
        jac.append(np.einsum("no,fni->foi", co, dx))
    return np.stack(jac, axis=-1)


def _central_diff(mna: MnaSystem, inputs: Sequence[Excitation], outputs: Sequence[Probe],
                  v: np.ndarray) -> np.ndarray:
    """Central differences with one Richardson step: (4 D(h/2) - D(h)) / 3, error O(h^4)."""
    def diff(p: int, h: float) -> np.ndarray:
        vp, vm = v.copy(), v.copy()
        vp[p] += h
        vm[p] -= h
        return (mna.response(F, inputs, outputs, vp, method="dense")
                - mna.response(F, inputs, outputs, vm, method="dense")) / (2 * h)

    jac = []
    for p in range(v.size):
        h = 1e-3 * abs(v[p])
        jac.append((4 * diff(p, h / 2) - diff(p, h)) / 3)
    return np.stack(jac, axis=-1)


@pytest.mark.parametrize("method", ["dense", "sparse", "hessenberg", "modal"])
def test_adjoint_sensitivities_match_forward_complex_step(method: SolveMethod) -> None:
    c = random_rlc_network(np.random.default_rng(7), n_nodes=8, n_elements=22)
    c = c.add_vccs("ctl.G", "0", "n3", "n1", "0", 1e-3)
    mna = c.mna
    inputs: list[Excitation] = ["V1", ("n2", "0")]
    outputs: list[Probe] = ["n4", ("n5", "n6"), "i(V1)"]
    v = mna.values0
    h, jac = mna.response_and_jacobian(F, inputs, outputs, method=method)
    ref = _forward_complex_step(mna, inputs, outputs, v)
    np.testing.assert_allclose(h, mna.response(F, inputs, outputs, method="dense"),
                               rtol=1e-8, atol=1e-14)
    # per parameter, relative to the largest derivative of that parameter
    err = np.max(np.abs(jac - ref), axis=(0, 1, 2)) / np.max(np.abs(ref), axis=(0, 1, 2))
    assert err.max() < 1e-6, dict(zip(mna.param_names, err, strict=True))
    # the mutual coupling and its inductors are among the parameters checked
    assert any(c.element(n).kind == "mutual" for n in mna.param_names)


def _coupled_ladder() -> Circuit:
    """A well-conditioned RLC ladder with a mutual coupling of two of its inductors."""
    c = Circuit().add_vsource("V1", "in", "0").add_resistor("Rs", "in", "x0", 50.0)
    for k in range(1, 6):
        c = c.add_inductor(f"lad.{k}.L", f"x{k - 1}", f"x{k}", 1e-6 * k)
        c = c.add_capacitor(f"lad.{k}.C", f"x{k}", "0", 1e-9)
        c = c.add_resistor(f"lad.{k}.R", f"x{k}", "0", 200.0 * k)
    c = c.add_mutual("lad.K", "lad.1.L", "lad.3.L", 0.3)
    return c


def test_adjoint_matches_central_differences_on_ladder() -> None:
    # a well-conditioned RLC ladder with coupling, where central differences reach ~1e-9
    c = _coupled_ladder()
    inputs, outputs = ["V1"], ["x5", "i(V1)"]
    _, jac = c.mna.response_and_jacobian(F, inputs, outputs)
    ref = _central_diff(c.mna, inputs, outputs, c.mna.values0)
    err = np.max(np.abs(jac - ref), axis=(0, 1, 2)) / np.max(np.abs(ref), axis=(0, 1, 2))
    assert err.max() < 1e-6, err


def test_jacobian_subset_of_params() -> None:
    c = random_rlc_network(np.random.default_rng(4), n_nodes=6, n_elements=16)
    names = [c.param_names[3], c.param_names[0]]
    _, full = c.mna.response_and_jacobian(F, ["V1"], ["n2"])
    _, sub = c.mna.response_and_jacobian(F, ["V1"], ["n2"], params=names)
    # only the selected parameters' triplets are summed: same values up to rounding
    np.testing.assert_allclose(sub[..., 0], full[..., 3], rtol=1e-12, atol=0)
    np.testing.assert_allclose(sub[..., 1], full[..., 0], rtol=1e-12, atol=0)


def test_jacobian_subset_with_coupled_inductor() -> None:
    # a selected inductor coupled by a mutual: its column includes dM/dL (M = k sqrt(L1 L3))
    # though the coupling itself is not selected; reference: the full Jacobian, which
    # test_adjoint_matches_central_differences_on_ladder checks against differences
    c = _coupled_ladder()
    names = ["lad.3.L", "lad.2.C", "lad.K"]
    _, full = c.mna.response_and_jacobian(F, ["V1"], ["x5", "i(V1)"])
    _, sub = c.mna.response_and_jacobian(F, ["V1"], ["x5", "i(V1)"], params=names)
    for j, n in enumerate(names):
        k = c.mna.param_names.index(n)
        scale = np.max(np.abs(full[..., k]))
        assert np.max(np.abs(sub[..., j] - full[..., k])) <= 1e-12 * scale, n


def test_poles_series_rlc_analytic() -> None:
    r, l_h, c_f = 10.0, 1e-6, 1e-9
    c = (Circuit().add_resistor("R", "a", "b", r).add_inductor("L", "b", "d", l_h)
         .add_capacitor("C", "d", "0", c_f).add_switch("S", "a", "0", closed=True))
    a = -r / (2 * l_h)
    w = np.sqrt(1 / (l_h * c_f) - a * a)
    p = network_poles(c)
    np.testing.assert_allclose(p, [a + 1j * w, a - 1j * w], rtol=1e-9)


def test_poles_rc_ladder_analytic() -> None:
    # n sections: series R, shunt C; input shorted, far end open.
    # G = (1/R) tridiag(-1, 2, -1) with last diagonal 1 -> s_k = -4 sin^2(th_k)/(RC),
    # th_k = (2k - 1) pi / (2 (2n + 1)), k = 1..n
    n, r, c_f = 12, 100.0, 1e-9
    c = Circuit()
    prev = "0"
    for k in range(1, n + 1):
        c = c.add_resistor(f"ladder.{k}.R", prev, f"x{k}", r)
        c = c.add_capacitor(f"ladder.{k}.C", f"x{k}", "0", c_f)
        prev = f"x{k}"
    th = (2 * np.arange(1, n + 1) - 1) * np.pi / (2 * (2 * n + 1))
    ref = np.sort(-4 * np.sin(th) ** 2 / (r * c_f))[::-1]
    p = network_poles(c)
    assert p.size == n and np.all(p.imag == 0)
    np.testing.assert_allclose(np.sort(p.real)[::-1], ref, rtol=1e-9)


def test_poles_coupled_rl_analytic() -> None:
    # identical coupled R-L loops: s = -R / (L (1 +- k)); plus a source row (infinite pole)
    r, l_h, k = 3.0, 1e-4, 0.6
    c = (Circuit().add_inductor("L1", "a", "0", l_h).add_resistor("R1", "a", "0", r)
         .add_inductor("L2", "b", "0", l_h).add_resistor("R2", "b", "0", r)
         .add_mutual("K", "L1", "L2", k).add_vsource("V", "c", "0")
         .add_resistor("Rc", "c", "a", 1e9))
    p = np.sort(network_poles(c).real)
    np.testing.assert_allclose(p, np.sort([-r / (l_h * (1 + k)), -r / (l_h * (1 - k))]),
                               rtol=1e-6)  # Rc = 1 GOhm perturbs the first loop by ~3e-9
    c_open = c.without(["Rc", "V"])
    p = np.sort(network_poles(c_open).real)
    np.testing.assert_allclose(p, np.sort([-r / (l_h * (1 + k)), -r / (l_h * (1 - k))]),
                               rtol=1e-9)


def test_poles_are_poles_of_the_response() -> None:
    c = random_rlc_network(np.random.default_rng(11), n_nodes=6, n_elements=14,
                           n_switches=0, n_mutual=1)
    p = network_poles(c)
    g, cm = c.mna.matrices()
    # det(G + p C) = 0: smallest singular value relative to the largest
    for pk in p:
        sv = np.linalg.svd(g + pk * cm, compute_uv=False)
        assert sv[-1] / sv[0] < 1e-9


def test_sparse_factorisation_fallback_gives_the_same_solution(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # _splu calls SuperLU's factorisation directly; when that private entry point is
    # missing or rejects its arguments (another SciPy) it falls back to splu: the three
    # paths must agree with the batched dense solve to rounding
    import vfmodel.circuit._solvers as solvers

    c = random_rlc_network(np.random.default_rng(11), n_nodes=9, n_elements=24)
    g, cm = c.mna.matrices()
    s = cast(NDArray[np.complex128], 2j * np.pi * F)
    b = c.mna.input_matrix(["V1"])
    cout = c.mna.output_matrix(["n3", "i(V1)"])
    ref = solvers.solve_dense(g, cm, s, b, cout, True)

    def rejects(*_a: object, **_k: object) -> None:
        raise TypeError("signature changed")

    assert solvers._GSTRF is not None    # this SciPy has the fast path
    for fast in (solvers._GSTRF, rejects, None):
        monkeypatch.setattr(solvers, "_GSTRF", fast)
        sol = solvers.solve_sparse(g, cm, s, b, cout, True)
        assert sol.x is not None and sol.lam is not None
        assert ref.x is not None and ref.lam is not None
        for got, want in ((sol.h, ref.h), (sol.x, ref.x), (sol.lam, ref.lam)):
            assert np.max(np.abs(got - want)) <= 1e-9 * np.max(np.abs(want))
        if fast is rejects:
            assert solvers._GSTRF is None    # a rejecting entry point is not tried again


def test_diagonal_jacobian_is_the_diagonal_of_the_full_one() -> None:
    # port input impedances only (the grey-box impedance term): the same numbers as the
    # diagonal of the full transfer-impedance Jacobian, which the complex-step test checks
    c = _coupled_ladder()
    ports = [("x1", "0"), ("x3", "x4"), ("x5", "0")]
    names = ["lad.1.L", "lad.4.C", "lad.K", "Rs"]
    h, full = c.mna.response_and_jacobian(F, ports, ports, params=names)
    hd, diag = c.mna.response_and_jacobian(F, ports, ports, params=names, diagonal=True)
    assert diag.shape == (F.size, 3, 4)
    np.testing.assert_allclose(hd, h, rtol=1e-13, atol=0)
    for k in range(3):
        ref = full[:, k, k, :]
        assert np.max(np.abs(diag[:, k, :] - ref)) <= 1e-12 * np.max(np.abs(ref))
    with pytest.raises(InputError, match="diagonal"):
        c.mna.response_and_jacobian(F, ports, ports[:2], diagonal=True)
