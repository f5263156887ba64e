"""Synthesis RationalModel -> Circuit, checked by the MNA engine (no ngspice)."""

from __future__ import annotations

import numpy as np
import pytest

from vfmodel.circuit.netlist import Circuit
from vfmodel.circuit.synthesis import model_to_spice, port_nodes, synthesize
from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import CircuitError

F = np.logspace(2, 7, 80)


def fitted_like_model(rng: np.random.Generator, n: int, kind: str, n_real: int = 2,
                      n_pair: int = 3) -> RationalModel:
    """A stable pole-residue model of the shape vector fitting produces.

    Real poles 1e3..1e7 rad/s, complex pairs with damping 5-30 %, symmetric residues
    (reciprocal network); Z/Y models get positive real-pole residues on the diagonal.
    """
    pr = -(10 ** rng.uniform(3, 7, n_real))
    wc = 10 ** rng.uniform(4, 7, n_pair)
    pc = -wc * rng.uniform(0.05, 0.3, n_pair) + 1j * wc

    def sym(x: np.ndarray) -> np.ndarray:
        return (x + np.swapaxes(x, -1, -2)) / 2

    rr = sym(rng.normal(size=(n_real, n, n))) + 3 * np.eye(n)
    rc = sym(rng.normal(size=(n_pair, n, n)) + 1j * rng.normal(size=(n_pair, n, n)))
    rr = rr * np.abs(pr)[:, None, None]
    rc = rc * np.abs(pc)[:, None, None]
    poles = np.concatenate([pr, np.ravel(np.column_stack([pc, pc.conj()]))])
    res = np.concatenate([rr, np.stack([x for r in rc for x in (r, r.conj())])])
    scale = {"Z": 100.0, "Y": 0.01, "S": 0.05}[kind]
    d = sym(rng.normal(size=(n, n))) * scale + 2 * scale * np.eye(n)
    e = np.zeros((n, n)) if kind == "S" else (sym(rng.normal(size=(n, n))) * 0.1
                                               + np.eye(n)) * scale * 1e-7
    return RationalModel(poles, res * scale, d, e, kind=kind,  # type: ignore[arg-type]
                         z0=50.0 if kind == "S" else None)


def circuit_response(c: Circuit, model: RationalModel) -> np.ndarray:
    pairs = [(p, "0") for p in port_nodes(model.n_in)]
    z = c.port_impedance(F, pairs)
    if model.kind == "Z":
        return z
    if model.kind == "Y":
        return np.linalg.inv(z)
    eye = np.eye(model.n_in)
    z0 = float(model.z0 or 50.0)
    return (z - z0 * eye) @ np.linalg.inv(z + z0 * eye)


@pytest.mark.parametrize(
    ("seed", "kind", "n", "form"),
    [(1, "Z", 1, "foster"), (2, "Y", 1, "foster"), (3, "Y", 1, "state_space"),
     (4, "Z", 1, "state_space"), (5, "Y", 3, "auto"), (6, "Z", 3, "auto"),
     (7, "S", 2, "auto")],
)
def test_synthesis_reproduces_model(seed: int, kind: str, n: int, form: str) -> None:
    rng = np.random.default_rng(seed)
    model = fitted_like_model(rng, n, kind)
    c = synthesize(model, form=form)
    assert [p.pos for p in c.ports] == list(port_nodes(n))
    h = circuit_response(c, model)
    ref = model(F)
    err = np.max(np.linalg.norm(h - ref, axis=(1, 2)) / np.linalg.norm(ref, axis=(1, 2)))
    assert err < 1e-9, err


def test_foster_elements_positive_for_rc_model() -> None:
    # Z = R0 + sum r/(s - p), r > 0, p < 0: a chain of positive parallel RC blocks
    model = RationalModel(np.array([-1e4, -1e6]), np.array([2e6, 5e7]), d=[[3.0]], kind="Z")  # type: ignore[arg-type]
    c = synthesize(model)
    kinds = sorted((e.kind, round(e.value, 12)) for e in c.elements)
    # C = 1/r, R = -r/p
    assert kinds == sorted([("capacitor", 5e-7), ("resistor", 200.0), ("capacitor", 2e-8),
                            ("resistor", 50.0), ("resistor", 3.0)])


def test_subckt_text_has_contract_pins() -> None:
    model = fitted_like_model(np.random.default_rng(5), 3, "Y")
    text = model_to_spice(model, name="vfmodel")
    lines = [ln for ln in text.splitlines() if not ln.startswith("*")]
    assert lines[0] == ".subckt vfmodel p1 p2 p3 ref"
    assert lines[-1] == ".ends"
    # no global ground inside: every node field of every card is a local node or 'ref'
    n_nodes = {"R": 2, "C": 2, "L": 2, "V": 2, "I": 2, "F": 2, "H": 2, "E": 4, "G": 4}
    for ln in lines[1:-1]:
        tok = ln.split()
        assert "0" not in tok[1:1 + n_nodes[tok[0][0]]], ln


def test_synthesis_errors() -> None:
    model = RationalModel(np.array([-1e4]), np.ones((1, 2, 1)), kind="H")  # type: ignore[arg-type]
    with pytest.raises(CircuitError, match="square"):
        synthesize(model)
    pair = RationalModel(np.array([-1e3 + 1e5j, -1e3 - 1e5j]), np.array([1e4j, -1e4j]),
                         kind="Y")
    with pytest.raises(CircuitError, match="purely imaginary residue"):
        synthesize(pair, form="foster")
    c = synthesize(pair, form="state_space")  # the state-space form realises it
    np.testing.assert_allclose(np.linalg.inv(c.port_impedance(F, [("p1", "0")])),
                               pair(F), rtol=1e-9)
