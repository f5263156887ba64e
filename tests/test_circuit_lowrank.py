"""Low-rank transfer updates (vfmodel.circuit.lowrank) against direct solves and the
adjoint Jacobian of the whole network (random RLC networks and a known divider)."""

from __future__ import annotations

import numpy as np
import pytest

from benches.random_networks import random_rlc_network
from vfmodel.circuit.lowrank import low_rank_transfer
from vfmodel.circuit.mna import MnaSystem
from vfmodel.circuit.netlist import Circuit

F = np.logspace(2, 7, 80)


def _moving(mna: MnaSystem, rng: np.random.Generator, k: int) -> np.ndarray:
    """``k`` random R/L/C elements that are not part of a mutual coupling."""
    mut = set(mna.mut_params.tolist()) | set(mna.mut_l1.tolist()) | set(mna.mut_l2.tolist())
    ok = [i for i, n in enumerate(mna.param_names)
          if i not in mut and n.split(".")[-1][:1] in "RLC" and n != "V1"]
    return np.sort(rng.choice(ok, size=k, replace=False))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_low_rank_matches_direct_solves(seed: int) -> None:
    rng = np.random.default_rng(seed)
    c = random_rlc_network(rng, n_elements=40)
    mna = c.mna
    b, cout = mna.input_matrix(["V1"]), mna.output_matrix(["n2", "n5"])
    v0 = mna.values()
    moving = _moving(mna, rng, 5)
    for direct in (True, False):
        lr = low_rank_transfer(mna, b, cout, v0, F, moving, direct=direct)
        assert lr is not None
        v = v0.copy()
        v[moving] *= np.exp(rng.normal(0.0, 1.5, moving.size))     # factors 0.05..20
        assert lr.applies(v, F)
        ref = mna.solve(F, b, cout, v, method="dense").h
        scale = np.abs(ref).max()
        # reference transfers from direct solves: rounding only; from the pole-residue
        # form: its own check tolerance (1e-5 of the largest response)
        tol = 1e-9 if direct else 1e-5
        assert np.abs(lr(v) - ref).max() <= tol * scale
        h, jac = lr.with_derivatives(v)
        href, jref = mna.response_and_jacobian(F, ["V1"], ["n2", "n5"], v,
                                               params=[mna.param_names[i] for i in moving])
        assert np.abs(h - href).max() <= tol * scale
        assert np.abs(jac - jref).max() <= (1e-7 if direct else 1e-4) * np.abs(jref).max()
        # a subset of the frequencies gives the same rows
        k = np.arange(3, F.size, 7)
        hk, jk = lr.with_derivatives(v, k)
        np.testing.assert_allclose(hk, h[k], rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(jk, jac[k], rtol=0, atol=1e-12 * np.abs(jac).max())


def test_low_rank_divider_analytic_and_applies() -> None:
    # V1 - R1 - out - (R2 || C2) - 0: H = Z2 / (R1 + Z2), Z2 = R2 / (1 + s R2 C2)
    c = (Circuit().add_vsource("V1", "in", "0").add_resistor("R1", "in", "out", 1e3)
         .add_resistor("R2", "out", "0", 2e3).add_capacitor("C2", "out", "0", 1e-9))
    mna = c.mna
    b, cout = mna.input_matrix(["V1"]), mna.output_matrix(["out"])
    v0 = mna.values()
    idx = [mna.param_names.index("R2"), mna.param_names.index("C2")]
    lr = low_rank_transfer(mna, b, cout, v0, F, np.array(idx))
    assert lr is not None
    v = v0.copy()
    v[idx] = [5e4, 3e-12]
    s = 2j * np.pi * F
    z2 = 5e4 / (1 + s * 5e4 * 3e-12)
    np.testing.assert_allclose(lr(v)[:, 0, 0], z2 / (1e3 + z2), rtol=1e-10)
    w = v.copy()
    w[mna.param_names.index("R1")] = 2e3          # a fixed element moved: not applicable
    assert not lr.applies(w)
    assert not lr.applies(v, F[:-1])               # other frequencies: not applicable
    assert not lr.applies(np.r_[v, 1.0])           # another network's values
