"""Circuit netlist: builder, parameters, checks with clear errors, SPICE round trip."""

from __future__ import annotations

import numpy as np
import pytest

from benches.random_networks import random_rlc_network
from vfmodel.circuit.netlist import Circuit
from vfmodel.circuit.spice_export import to_spice
from vfmodel.circuit.spice_import import from_spice, parse_value
from vfmodel.errors import CircuitError


def _rc() -> Circuit:
    return (Circuit().add_vsource("src.U", "U", "0")
            .add_resistor("bearing.nde.lubricant.oil.R", "U", "SN", 1e3)
            .add_capacitor("bearing.nde.lubricant.oil.C", "SN", "0", 1e-9))


def test_builder_names_nodes_params() -> None:
    c = _rc()
    assert c.nodes == ("U", "SN")
    assert c.param_names == ("bearing.nde.lubricant.oil.R", "bearing.nde.lubricant.oil.C")
    c2 = c.with_params({"bearing.nde.lubricant.oil.R": 2e3})
    assert c2.element("bearing.nde.lubricant.oil.R").value == 2e3
    assert c.element("bearing.nde.lubricant.oil.R").value == 1e3  # immutable
    c3 = c.with_params([5.0, 7e-9])
    np.testing.assert_array_equal(c3.param_values, [5.0, 7e-9])


def test_include_prefixes_names_and_nodes() -> None:
    sub = Circuit().add_resistor("R", "a", "mid", 1.0).add_capacitor("C", "mid", "0", 1e-9)
    c = Circuit().add_vsource("V1", "x", "0").include(sub, "lub", {"a": "x"})
    assert [e.name for e in c.elements] == ["V1", "lub.R", "lub.C"]
    assert c.nodes == ("x", "lub.mid")
    # the included RC divides: v(mid)/v(x) = 1/(1 + sRC) (analytic)
    f = np.array([1e3, 1.59e8])
    h = c.transfer(["V1"], ["lub.mid"])(f)[:, 0, 0]
    np.testing.assert_allclose(h, 1 / (1 + 2j * np.pi * f * 1e-9), rtol=1e-12)


@pytest.mark.parametrize(
    ("build", "needle"),
    [
        (lambda: Circuit().add_resistor("a.R", "x", "0", 0.0), "'a.R' (resistor): value 0"),
        (lambda: Circuit().add_capacitor("a.C", "x", "0", -1e-9), "'a.C' (capacitor): negative"),
        (lambda: Circuit().add_inductor("a.L", "x", "0", float("nan")), "'a.L' (inductor)"),
        (lambda: Circuit().add_inductor("L1", "x", "0", 1e-6).add_inductor("L2", "y", "0", 1)
         .add_mutual("K1", "L1", "L2", 1.5), "'K1' (mutual): coupling coefficient 1.5"),
        (lambda: Circuit().add_vsource("V1", "x", "x"), "'V1' (vsource): voltage source short"),
        (lambda: Circuit().add_resistor("R1", "x", "0", 1).add_resistor("R1", "y", "0", 1),
         "'R1' is used twice"),
    ],
)
def test_bad_values_name_the_element(build, needle: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(CircuitError, match=needle.replace("(", r"\(").replace(")", r"\)")):
        build()


def test_floating_node_error_names_node() -> None:
    c = (Circuit().add_vsource("V1", "a", "0").add_resistor("R1", "a", "0", 1.0)
         .add_isource("I1", "b", "0").add_switch("S1", "b", "a", closed=False))
    with pytest.raises(CircuitError, match=r"floating node 'b'.*I1, S1"):
        c.check()
    with pytest.raises(CircuitError, match="floating node 'b'"):
        c.mna  # noqa: B018
    c.with_switches({"S1": True}).check()  # closing the switch joins b to a


def test_short_circuited_source_error() -> None:
    c = (Circuit().add_vsource("V1", "a", "0").add_resistor("R1", "a", "0", 1.0)
         .add_switch("S1", "a", "0", closed=True))
    with pytest.raises(CircuitError, match=r"'S1' \(switch\): voltage source short-circuited"):
        c.check()
    c2 = Circuit().add_vsource("V1", "a", "0").add_vsource("V2", "a", "0")
    with pytest.raises(CircuitError, match=r"'V2'.*short-circuited"):
        c2.check()


def test_parameter_value_checked_at_evaluation() -> None:
    c = _rc()
    with pytest.raises(CircuitError, match=r"'bearing\.nde\.lubricant\.oil\.C'.*not allowed"):
        c.mna.response([1e3], ["src.U"], ["SN"], [1e3, -1e-9])


def test_parse_value_suffixes() -> None:
    assert parse_value("1.5k") == 1500.0
    assert parse_value("10pF") == pytest.approx(1e-11, rel=1e-15)
    assert parse_value("2Meg") == 2e6
    assert parse_value("3m") == pytest.approx(3e-3, rel=1e-15)
    assert parse_value("-4.7e-3u") == pytest.approx(-4.7e-9, rel=1e-15)
    with pytest.raises(CircuitError, match="not a SPICE number"):
        parse_value("abc", "x.cir")


def test_spice_round_trip_preserves_response() -> None:
    c = random_rlc_network(np.random.default_rng(3), n_elements=34)
    c = c.add_conductance("extra.G", "n2", "0", 1e-3)
    text = to_spice(c)
    back = from_spice(text)
    assert [e.name for e in back.elements if e.kind != "switch"] == \
        [e.name for e in c.elements if e.kind != "switch"]
    assert sorted(e.name for e in back.elements) == sorted(e.name for e in c.elements)
    f = np.logspace(2, 7, 30)
    h0 = c.ac(f, list(c.nodes))
    h1 = back.ac(f, list(c.nodes))
    # values are written with 17 significant digits: identical response
    np.testing.assert_allclose(h1, h0, rtol=1e-12, atol=0)


def test_import_plain_spice() -> None:
    text = """rc divider
* comment
V1 in 0 DC 1 AC 2
R1 in out 1k ; inline comment
C1 out 0
+ 1n
.ac dec 10 1 1meg
.control
run
.endc
.end
"""
    c = from_spice(text)
    assert c.title == "rc divider"
    assert [e.kind for e in c.elements] == ["vsource", "resistor", "capacitor"]
    f = np.array([1e5])
    np.testing.assert_allclose(c.ac(f, ["out"])[:, 0],
                               2 / (1 + 2j * np.pi * f * 1e3 * 1e-9), rtol=1e-12)
    with pytest.raises(CircuitError, match=r"line 2: '\.subckt' is not supported"):
        from_spice("t\n.subckt x a b\n.ends\n")
    with pytest.raises(CircuitError, match=r"line 2: element 'D1' is not supported"):
        from_spice("t\nD1 a 0 dmod\n")


def test_imported_netlist_errors_name_the_element() -> None:
    with pytest.raises(CircuitError, match=r"'R1' \(resistor\): value 0 is not allowed"):
        from_spice("t\nV1 a 0 AC 1\nR1 a 0 0\n")
    with pytest.raises(CircuitError, match=r"'C1' \(capacitor\): negative value -1e-09"):
        from_spice("t\nV1 a 0 AC 1\nR1 a 0 1k\nC1 a 0 -1n\n")
    floating = from_spice("t\nV1 a 0 AC 1\nR1 a 0 1k\nR2 b c 1k\n")
    with pytest.raises(CircuitError, match=r"floating node 'b'.*R2"):
        floating.check()
    with pytest.raises(CircuitError, match=r"'V2' \(vsource\): voltage source short-circuited"):
        from_spice("t\nV1 a 0 AC 1\nR1 a 0 1k\nV2 a 0 AC 0\n").check()
