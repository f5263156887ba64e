"""`Circuit`: an immutable netlist of linear elements with hierarchical names.

Elements (``kind``, nodes, value):

==============  ==========================  =====================================
kind            nodes                       value (parameter)
==============  ==========================  =====================================
``resistor``    (n+, n-)                    resistance, ohm
``conductance`` (n+, n-)                    conductance, S (0 = open)
``inductor``    (n+, n-)                    inductance, H
``capacitor``   (n+, n-)                    capacitance, F
``mutual``      ()  refs=(L1, L2)           coupling coefficient k, 0 < |k| <= 1
``switch``      (n+, n-)                    ideal switch; ``closed`` is a state
``vsource``     (n+, n-)                    AC amplitude, V (v(n+) - v(n-))
``isource``     (n+, n-)                    AC amplitude, A (flows n+ -> source -> n-)
``vcvs``        (n+, n-, nc+, nc-)          voltage gain
``vccs``        (n+, n-, nc+, nc-)          transconductance, S (n+ -> source -> n-)
``cccs``        (n+, n-)  refs=(Vctrl,)     current gain (n+ -> source -> n-)
``ccvs``        (n+, n-)  refs=(Vctrl,)     transresistance, ohm
==============  ==========================  =====================================

Element names are free strings without white space, conventionally hierarchical
(``bearing.nde.lubricant.oil.R``); the value of every element except sources and switches
is a parameter addressed by the element's name (:attr:`Circuit.param_names`,
:meth:`Circuit.with_params`). Source values are the AC amplitudes used by
:meth:`Circuit.ac`; transfer functions are per unit source. The ground node is
``Circuit.ground`` (``"0"``).

The builder methods (``add_resistor`` ...) return a new ``Circuit``; the element values are
checked there (an error names the element). The topology (floating nodes, loops of voltage
sources) is checked by :meth:`Circuit.check`, which the MNA compilation calls.

Identification loop (no netlist rebuilt per evaluation)::

    mna = circuit.mna                                   # compiled once (cached)
    names = mna.param_names                             # order of value vectors
    z = mna.response(f, [("U", "0")], [("U", "0")], values)           # U-Frame, others open
    h, dh = mna.response_and_jacobian(f, ["src.U", "src.V", "src.W"], ["SN"], values,
                                      method="modal")  # (n_f,1,3), (n_f,1,3,n_params)

A topology variant (sources removed to open the terminals, a switch state) is another
``Circuit`` (:meth:`Circuit.without`, :meth:`Circuit.with_switches`) with its own ``mna``.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import TYPE_CHECKING, Literal, get_args

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vfmodel.errors import CircuitError

if TYPE_CHECKING:  # pragma: no cover
    from vfmodel.circuit.mna import CircuitTransfer, MnaSystem

Probe = str | tuple[str, str]
"""An output: node name (voltage to ground), node pair (difference) or ``"i(name)"``
(branch current of a voltage source, inductor, switch, VCVS or CCVS)."""
Excitation = str | tuple[str, str]
"""An input: name of an independent source (unit amplitude) or a node pair (p, n) into which
a unit current is injected at p and drawn from n."""

ElementKind = Literal[
    "resistor",
    "conductance",
    "inductor",
    "capacitor",
    "mutual",
    "switch",
    "vsource",
    "isource",
    "vcvs",
    "vccs",
    "cccs",
    "ccvs",
]
ELEMENT_KINDS: tuple[str, ...] = get_args(ElementKind)

_TWO_NODE = {"resistor", "conductance", "inductor", "capacitor", "switch", "vsource", "isource",
             "cccs", "ccvs"}
_FOUR_NODE = {"vcvs", "vccs"}
_NO_PARAM = {"switch", "vsource", "isource"}
# kinds whose branch equation fixes a voltage (a loop of them short-circuits a source)
VOLTAGE_DEFINED = {"vsource", "vcvs", "ccvs", "switch"}


@dataclass(frozen=True)
class Element:
    """One circuit element; see the module docstring for the meaning of each field."""

    name: str
    kind: ElementKind
    nodes: tuple[str, ...]
    value: float = 0.0
    refs: tuple[str, ...] = ()
    closed: bool = True

    @property
    def is_parameter(self) -> bool:
        """True when :attr:`value` is an identification parameter."""
        return self.kind not in _NO_PARAM


@dataclass(frozen=True)
class Port:
    """A named port: voltage ``v(pos) - v(neg)``, current into ``pos``."""

    name: str
    pos: str
    neg: str


def _check_name(name: object, what: str) -> str:
    # name.split() == [name]: non-empty and no white space (str.isspace characters)
    if not isinstance(name, str) or name.split() != [name]:
        raise CircuitError(f"{what} name {name!r} is not valid: expected a non-empty string "
                           "without white space")
    return name


def check_value(el: Element, value: float, allow_negative: bool) -> None:
    """Raise CircuitError naming ``el`` when ``value`` is not allowed for its kind."""
    if not np.isfinite(value):
        raise CircuitError(f"element {el.name!r} ({el.kind}): value {value!r} is not finite")
    if el.kind in ("resistor", "inductor", "capacitor"):
        if value == 0.0:
            raise CircuitError(
                f"element {el.name!r} ({el.kind}): value 0 is not allowed "
                "(use a switch for a short or remove the element for an open)"
            )
        if value < 0 and not allow_negative:
            raise CircuitError(
                f"element {el.name!r} ({el.kind}): negative value {value!r} is not allowed "
                "(expected > 0; Circuit(allow_negative=True) accepts it)"
            )
    elif el.kind == "conductance":
        if value < 0 and not allow_negative:
            raise CircuitError(
                f"element {el.name!r} (conductance): negative value {value!r} is not allowed "
                "(expected >= 0)"
            )
    elif el.kind == "mutual" and not (0 < abs(value) <= 1):
        raise CircuitError(
            f"element {el.name!r} (mutual): coupling coefficient {value!r} not allowed "
            "(expected 0 < |k| <= 1)"
        )


class NodeSets:
    """Disjoint sets of node names (union-find with path halving): which nodes are
    connected through a set of two-terminal elements."""

    def __init__(self) -> None:
        self._parent: dict[str, str] = {}

    def find(self, n: str) -> str:
        """Representative of ``n``'s set (``n`` itself when first seen)."""
        parent = self._parent
        while parent.setdefault(n, n) != n:
            parent[n] = parent[parent[n]]
            n = parent[n]
        return n

    def union(self, a: str, b: str) -> bool:
        """Join the sets of ``a`` and ``b``; False when they were one set already."""
        ra, rb = self.find(a), self.find(b)
        if ra == rb:
            return False
        self._parent[ra] = rb
        return True


@dataclass(frozen=True)
class Circuit:
    """Immutable netlist of linear elements (see the module docstring).

    Parameters
    ----------
    elements : tuple of Element
    ports : tuple of Port
    ground : str
        Name of the reference node, ``"0"``.
    title : str
        First line of an exported SPICE netlist.
    allow_negative : bool
        Accept negative R, L, C and conductance (synthesised networks may need them).
    """

    elements: tuple[Element, ...] = ()
    ports: tuple[Port, ...] = ()
    ground: str = "0"
    title: str = "vfmodel circuit"
    allow_negative: bool = False
    _index: dict[str, int] = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        index: dict[str, int] = {}
        for i, el in enumerate(self.elements):
            if el.name in index:
                raise CircuitError(f"element name {el.name!r} is used twice")
            index[el.name] = i
        object.__setattr__(self, "_index", index)
        for el in self.elements:
            self._check_element(el, index)
        names = set()
        for p in self.ports:
            if p.name in names:
                raise CircuitError(f"port name {p.name!r} is used twice")
            names.add(p.name)

    def _check_element(self, el: Element, index: Mapping[str, int]) -> None:
        _check_name(el.name, "element")
        if el.kind not in ELEMENT_KINDS:
            raise CircuitError(f"element {el.name!r}: unknown kind {el.kind!r} "
                               f"(expected one of {', '.join(ELEMENT_KINDS)})")
        n_nodes = 2 if el.kind in _TWO_NODE else 4 if el.kind in _FOUR_NODE else 0
        if len(el.nodes) != n_nodes:
            raise CircuitError(f"element {el.name!r} ({el.kind}): {len(el.nodes)} nodes given, "
                               f"expected {n_nodes}")
        for n in el.nodes:
            _check_name(n, f"node of element {el.name!r}:")
        check_value(el, float(el.value), self.allow_negative)
        if el.kind == "mutual":
            if len(el.refs) != 2 or el.refs[0] == el.refs[1]:
                raise CircuitError(f"element {el.name!r} (mutual): expected two distinct "
                                   f"inductor names, got {el.refs!r}")
            for r in el.refs:
                if r not in index or self.elements[index[r]].kind != "inductor":
                    raise CircuitError(f"element {el.name!r} (mutual): {r!r} is not an "
                                       "inductor of the circuit (add the inductors first)")
        if el.kind in ("cccs", "ccvs"):
            if len(el.refs) != 1 or el.refs[0] not in index or \
                    self.elements[index[el.refs[0]]].kind != "vsource":
                raise CircuitError(f"element {el.name!r} ({el.kind}): controlling element "
                                   f"{el.refs!r} must name one voltage source of the circuit")
        if el.kind in _TWO_NODE and el.kind != "isource" and el.nodes[0] == el.nodes[1]:
            if el.kind in ("vsource", "vcvs", "ccvs"):
                raise CircuitError(f"element {el.name!r} ({el.kind}): voltage source "
                                   f"short-circuited (both terminals on node {el.nodes[0]!r})")
            raise CircuitError(f"element {el.name!r} ({el.kind}): both terminals on node "
                               f"{el.nodes[0]!r}")

    # ------------------------------------------------------------------ building
    def add(self, element: Element) -> Circuit:
        """A new circuit with ``element`` appended."""
        if element.name in self._index:
            raise CircuitError(f"element name {element.name!r} is used twice")
        self._check_element(element, {**self._index, element.name: len(self.elements)})
        return replace(self, elements=(*self.elements, element))

    def extend(self, elements: Iterable[Element]) -> Circuit:
        """A new circuit with all ``elements`` appended (checked once)."""
        return replace(self, elements=(*self.elements, *elements))

    def add_resistor(self, name: str, n1: str, n2: str, r_ohm: float) -> Circuit:
        return self.add(Element(name, "resistor", (n1, n2), float(r_ohm)))

    def add_conductance(self, name: str, n1: str, n2: str, g_s: float) -> Circuit:
        return self.add(Element(name, "conductance", (n1, n2), float(g_s)))

    def add_inductor(self, name: str, n1: str, n2: str, l_h: float) -> Circuit:
        return self.add(Element(name, "inductor", (n1, n2), float(l_h)))

    def add_capacitor(self, name: str, n1: str, n2: str, c_f: float) -> Circuit:
        return self.add(Element(name, "capacitor", (n1, n2), float(c_f)))

    def add_mutual(self, name: str, inductor1: str, inductor2: str, k: float) -> Circuit:
        """Coupling ``k`` between two inductors (dots on their first nodes), M = k sqrt(L1 L2)."""
        return self.add(Element(name, "mutual", (), float(k), refs=(inductor1, inductor2)))

    def add_switch(self, name: str, n1: str, n2: str, closed: bool) -> Circuit:
        """Ideal switch: closed = zero-volt branch, open = zero-current branch."""
        return self.add(Element(name, "switch", (n1, n2), 0.0, closed=bool(closed)))

    def add_vsource(self, name: str, n_pos: str, n_neg: str, ac: float = 1.0) -> Circuit:
        return self.add(Element(name, "vsource", (n_pos, n_neg), float(ac)))

    def add_isource(self, name: str, n_from: str, n_to: str, ac: float = 1.0) -> Circuit:
        """Current source; the current flows from ``n_from`` through the source to ``n_to``."""
        return self.add(Element(name, "isource", (n_from, n_to), float(ac)))

    def add_vcvs(self, name: str, n_pos: str, n_neg: str, c_pos: str, c_neg: str,
                 gain: float) -> Circuit:
        return self.add(Element(name, "vcvs", (n_pos, n_neg, c_pos, c_neg), float(gain)))

    def add_vccs(self, name: str, n_from: str, n_to: str, c_pos: str, c_neg: str,
                 gm_s: float) -> Circuit:
        return self.add(Element(name, "vccs", (n_from, n_to, c_pos, c_neg), float(gm_s)))

    def add_cccs(self, name: str, n_from: str, n_to: str, vsource: str, gain: float) -> Circuit:
        return self.add(Element(name, "cccs", (n_from, n_to), float(gain), refs=(vsource,)))

    def add_ccvs(self, name: str, n_pos: str, n_neg: str, vsource: str, r_ohm: float) -> Circuit:
        return self.add(Element(name, "ccvs", (n_pos, n_neg), float(r_ohm), refs=(vsource,)))

    def add_port(self, name: str, pos: str, neg: str) -> Circuit:
        return replace(self, ports=(*self.ports, Port(name, pos, neg)))

    def include(self, sub: Circuit, prefix: str, node_map: Mapping[str, str]) -> Circuit:
        """Add a copy of ``sub`` with element names ``prefix.name``.

        ``node_map`` maps nodes of ``sub`` to nodes of this circuit; other nodes of ``sub``
        become ``prefix.node``; the ground of ``sub`` maps to this ground unless mapped.
        """
        def node(n: str) -> str:
            if n in node_map:
                return node_map[n]
            return self.ground if n == sub.ground else f"{prefix}.{n}"

        new = [
            replace(el, name=f"{prefix}.{el.name}", nodes=tuple(node(n) for n in el.nodes),
                    refs=tuple(f"{prefix}.{r}" for r in el.refs))
            for el in sub.elements
        ]
        return self.extend(new)

    # ------------------------------------------------------------------ access
    def __len__(self) -> int:
        return len(self.elements)

    def __contains__(self, name: object) -> bool:
        return name in self._index

    def element(self, name: str) -> Element:
        """The element called ``name`` (CircuitError if absent)."""
        try:
            return self.elements[self._index[name]]
        except KeyError:
            raise CircuitError(f"no element named {name!r} in the circuit") from None

    @cached_property
    def nodes(self) -> tuple[str, ...]:
        """Non-ground nodes in order of first appearance."""
        seen: dict[str, None] = {}
        for el in self.elements:
            for n in el.nodes:
                if n != self.ground:
                    seen.setdefault(n, None)
        for p in self.ports:
            for n in (p.pos, p.neg):
                if n != self.ground:
                    seen.setdefault(n, None)
        return tuple(seen)

    @cached_property
    def param_names(self) -> tuple[str, ...]:
        """Names of the elements whose value is a parameter, in netlist order."""
        return tuple(el.name for el in self.elements if el.is_parameter)

    @property
    def param_values(self) -> NDArray[np.float64]:
        """Parameter values in the order of :attr:`param_names`."""
        return np.array([el.value for el in self.elements if el.is_parameter], dtype=float)

    def with_params(self, values: Mapping[str, float] | ArrayLike) -> Circuit:
        """A new circuit with parameter values changed (mapping by name, or a full vector)."""
        if isinstance(values, Mapping):
            for k in values:
                if k not in self._index or not self.element(k).is_parameter:
                    raise CircuitError(f"with_params: {k!r} is not a parameter of the circuit")
            new = [replace(el, value=float(values[el.name])) if el.name in values else el
                   for el in self.elements]
        else:
            v = np.asarray(values, dtype=float).ravel()
            if v.size != len(self.param_names):
                raise CircuitError(f"with_params: {v.size} values given, expected "
                                   f"{len(self.param_names)}")
            it = iter(v.tolist())
            new = [replace(el, value=next(it)) if el.is_parameter else el
                   for el in self.elements]
        return replace(self, elements=tuple(new))

    def with_switches(self, states: Mapping[str, bool]) -> Circuit:
        """A new circuit with switch states changed (``True`` = closed)."""
        for k in states:
            if k not in self._index or self.element(k).kind != "switch":
                raise CircuitError(f"with_switches: {k!r} is not a switch of the circuit")
        new = [replace(el, closed=bool(states[el.name])) if el.name in states else el
               for el in self.elements]
        return replace(self, elements=tuple(new))

    def without(self, names: Iterable[str]) -> Circuit:
        """A new circuit without the named elements (e.g. sources, to open terminals)."""
        drop = set(names)
        for k in drop:
            self.element(k)
        keep = [el for el in self.elements if el.name not in drop]
        for el in keep:
            if drop.intersection(el.refs):
                raise CircuitError(f"without: element {el.name!r} refers to a removed element")
        return replace(self, elements=tuple(keep))

    # ------------------------------------------------------------------ checks
    def check(self) -> None:
        """Raise CircuitError for a floating node or a loop of voltage-defined branches.

        A node floats when no path of resistors, conductances, inductors, capacitors,
        closed switches or source outputs joins it to ground. Independent current sources
        and controlling terminals have infinite impedance; the outputs of controlled current
        sources count as paths (a VCCS controlled by its own terminals is a conductance,
        and synthesised port models rely on it), so a network made singular by controlled
        sources alone is reported by the solver instead. A loop of voltage sources,
        VCVS/CCVS outputs and closed switches short-circuits a source.
        """
        g = self.ground
        conn, vconn = NodeSets(), NodeSets()
        find = conn.find

        for el in self.elements:
            if el.kind in ("isource", "mutual"):
                continue
            if el.kind == "switch" and not el.closed:
                continue
            if el.kind == "conductance" and el.value == 0.0:
                continue
            a, b = el.nodes[0], el.nodes[1]
            conn.union(a, b)
            if el.kind in VOLTAGE_DEFINED:
                if not vconn.union(a, b):
                    raise CircuitError(
                        f"element {el.name!r} ({el.kind}): voltage source short-circuited "
                        f"(closes a loop of voltage sources/closed switches between nodes "
                        f"{a!r} and {b!r})"
                    )
        root = find(g)
        floating = [n for n in self.nodes if find(n) != root]
        if floating:
            n = floating[0]
            touching = [el.name for el in self.elements if n in el.nodes]
            raise CircuitError(
                f"floating node {n!r}: no path to ground {g!r} through passive elements, "
                f"closed switches or source outputs (connected to: "
                f"{', '.join(touching) or 'nothing'}); {len(floating)} floating node(s) in all"
            )

    # ------------------------------------------------------------------ analysis
    @cached_property
    def mna(self) -> MnaSystem:
        """The compiled MNA system (topology checked; cached)."""
        from vfmodel.circuit.mna import MnaSystem

        return MnaSystem.from_circuit(self)

    def transfer(self, inputs: Sequence[Excitation],
                 outputs: Sequence[Probe]) -> CircuitTransfer:
        """Callable ``H(freq_hz) -> (n_freq, n_out, n_in)``; see :meth:`MnaSystem.response`."""
        from vfmodel.circuit.mna import CircuitTransfer

        return CircuitTransfer(self.mna, tuple(inputs), tuple(outputs))

    def port_impedance(self, freq_hz: ArrayLike,
                       ports: Sequence[tuple[str, str]] | None = None) -> NDArray[np.complex128]:
        """Open-circuit impedance matrix (n_freq, n_ports, n_ports) between node pairs.

        ``ports`` defaults to :attr:`ports`. Other terminals are left open (no source).
        """
        pairs = [(p.pos, p.neg) for p in self.ports] if ports is None else list(ports)
        return self.mna.response(freq_hz, pairs, pairs)

    def port_admittance(self, freq_hz: ArrayLike,
                        ports: Sequence[tuple[str, str]] | None = None
                        ) -> NDArray[np.complex128]:
        """Short-circuit admittance matrix: inverse of :meth:`port_impedance`."""
        return np.asarray(np.linalg.inv(self.port_impedance(freq_hz, ports)), dtype=complex)

    def ac(self, freq_hz: ArrayLike, outputs: Sequence[Probe]) -> NDArray[np.complex128]:
        """AC response (n_freq, n_out) with every independent source at its AC value."""
        return self.mna.ac(freq_hz, outputs)

    def poles(self) -> NDArray[np.complex128]:
        """Natural frequencies (rad/s) with sources set to zero; see ``poles.network_poles``."""
        from vfmodel.circuit.poles import network_poles

        return network_poles(self)

