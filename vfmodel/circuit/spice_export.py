"""Export a :class:`Circuit` as an ngspice netlist (flat, or as a ``.subckt``).

Element mapping (``name`` = SPICE name derived from the hierarchical name):

- resistor ``R``; capacitor ``C``; inductor ``L``; mutual coupling ``K L1 L2 k``;
- conductance ``g``: resistor ``R = 1/g`` (``g = 0`` is an open: no card);
- ideal switch: closed = 0 V voltage source ``V name n1 n2 DC 0`` (exact, like the MNA
  model); open = no card (a comment keeps it);
- voltage / current source ``V|I name n+ n- DC 0 AC value [transient spec]``;
- VCVS ``E``, VCCS ``G``, CCCS ``F``, CCVS ``H``.

SPICE names are case-insensitive and restricted, so each name is the kind letter followed
by the hierarchical name with every character other than letters, digits and ``_``
replaced by ``_`` (``bearing.nde.lubricant.oil.R`` -> ``R_bearing_nde_lubricant_oil_R``),
made unique. Node names are sanitised the same way (``U``, ``V``, ``W``, ``SN`` and the
ground ``0`` are kept). Comment lines ``* vfmodel: SPICE-NAME KIND ORIGINAL-NAME`` and
``* vfmodel-node: SPICE-NODE ORIGINAL-NODE`` record the mapping;
:func:`vfmodel.circuit.spice_import.from_spice` reads them back.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

from vfmodel.circuit.netlist import Circuit, Element
from vfmodel.errors import CircuitError

_LETTER = {
    "resistor": "R", "conductance": "R", "inductor": "L", "capacitor": "C", "mutual": "K",
    "switch": "V", "vsource": "V", "isource": "I", "vcvs": "E", "vccs": "G", "cccs": "F",
    "ccvs": "H",
}
_BAD = re.compile(r"[^A-Za-z0-9_]")


def _num(x: float) -> str:
    return f"{x:.17g}"


def _unique(base: str, used: set[str]) -> str:
    name, k = base, 2
    while name.lower() in used:
        name = f"{base}_{k}"
        k += 1
    used.add(name.lower())
    return name


def spice_names(circuit: Circuit) -> tuple[dict[str, str], dict[str, str]]:
    """SPICE names of the elements and nodes: ``(element_map, node_map)``."""
    used: set[str] = set()
    emap: dict[str, str] = {}
    for el in circuit.elements:
        letter = _LETTER[el.kind]
        body = _BAD.sub("_", el.name)
        if body[0].upper() == letter and body == el.name and el.kind != "switch":
            base = body
        else:
            base = f"{letter}_{body}"
        emap[el.name] = _unique(base, used)
    nused: set[str] = {"0"}
    nmap: dict[str, str] = {circuit.ground: "0"}
    for n in circuit.nodes:
        base = _BAD.sub("_", n)
        if base == "0" or base.lower() == "gnd":
            base = f"n_{base}"
        nmap[n] = _unique(base, nused)
    return emap, nmap


def _wrap(card: str, width: int = 200) -> list[str]:
    """Split a long card into continuation lines at spaces."""
    if len(card) <= width:
        return [card]
    out: list[str] = []
    cur = ""
    for tok in card.split(" "):
        if cur and len(cur) + 1 + len(tok) > width:
            out.append(cur)
            cur = "+ " + tok
        else:
            cur = f"{cur} {tok}" if cur else tok
    out.append(cur)
    return out


def to_spice(
    circuit: Circuit,
    *,
    subckt: str | None = None,
    pins: Sequence[str] = (),
    ground_pin: str = "ref",
    source_specs: Mapping[str, str] | None = None,
    title: str | None = None,
    extra_lines: Sequence[str] = (),
) -> str:
    """ngspice netlist text of ``circuit``.

    Parameters
    ----------
    circuit : Circuit
    subckt : str, optional
        Write ``.subckt SUBCKT pins... ground_pin`` ... ``.ends`` instead of a flat netlist;
        the circuit's ground becomes the pin ``ground_pin`` (no global ground inside).
    pins : sequence of str
        Circuit nodes that become subcircuit pins (in order), e.g. the port nodes.
    source_specs : mapping, optional
        Transient specification appended to a source card, by element name, e.g.
        ``{"src.U": "PWL(0 0 1u 1)"}``.
    title : str, optional
        First line (default ``circuit.title``); ignored for a subcircuit.
    extra_lines : sequence of str
        Lines appended before ``.end`` (analysis cards, ``.options``).

    Returns
    -------
    str
        Netlist text (flat: ending with ``.end``; subcircuit: ``.subckt`` ... ``.ends``).
    """
    circuit.check()
    specs = dict(source_specs or {})
    for k in specs:
        if circuit.element(k).kind not in ("vsource", "isource"):
            raise CircuitError(f"source_specs: {k!r} is not an independent source")
    emap, nmap = spice_names(circuit)
    if subckt is not None:
        if _BAD.search(subckt) or _BAD.search(ground_pin):
            raise CircuitError(f"subckt name {subckt!r} / ground pin {ground_pin!r} must be "
                               "letters, digits and '_'")
        nmap[circuit.ground] = ground_pin
        for n in list(nmap):
            if n != circuit.ground and nmap[n].lower() == ground_pin.lower():
                nmap[n] = nmap[n] + "_node"
        for p in pins:
            if p not in nmap:
                raise CircuitError(f"pin {p!r} is not a node of the circuit")
    lines: list[str] = []
    if subckt is None:
        lines.append(title or circuit.title)
    lines.append("* exported by vfmodel; mapping of names in '* vfmodel' comments")
    for n, sn in nmap.items():
        if n != sn and n != circuit.ground:
            lines.append(f"* vfmodel-node: {sn} {n}")
    if subckt is not None:
        pin_nodes = [nmap[p] for p in pins]
        lines.append(f".subckt {subckt} {' '.join([*pin_nodes, ground_pin])}")
    for el in circuit.elements:
        lines.extend(_card(el, emap, nmap, specs.get(el.name)))
    lines.extend(extra_lines)
    lines.append(".ends" if subckt is not None else ".end")
    return "\n".join(lines) + "\n"


def _card(el: Element, emap: Mapping[str, str], nmap: Mapping[str, str],
          spec: str | None) -> list[str]:
    name = emap[el.name]
    nodes = " ".join(nmap[n] for n in el.nodes)
    head = f"* vfmodel: {name} {el.kind} {el.name}"
    k = el.kind
    if k == "resistor":
        card = f"{name} {nodes} {_num(el.value)}"
    elif k == "conductance":
        if el.value == 0.0:
            return [head + f" (open: g = 0 between {nodes})"]
        card = f"{name} {nodes} {_num(1.0 / el.value)}"
    elif k in ("inductor", "capacitor"):
        card = f"{name} {nodes} {_num(el.value)}"
    elif k == "mutual":
        card = f"{name} {emap[el.refs[0]]} {emap[el.refs[1]]} {_num(el.value)}"
    elif k == "switch":
        if not el.closed:
            return [f"* vfmodel-open-switch: {name} {el.name} {nodes}"]
        card = f"{name} {nodes} DC 0"
    elif k in ("vsource", "isource"):
        card = f"{name} {nodes} DC 0 AC {_num(el.value)}" + (f" {spec}" if spec else "")
    elif k in ("vcvs", "vccs"):
        card = f"{name} {nodes} {_num(el.value)}"
    else:  # cccs, ccvs
        card = f"{name} {nodes} {emap[el.refs[0]]} {_num(el.value)}"
    return [head, *_wrap(card)]


def delayed_subckt(rational: str, rational_name: str, name: str, n_ports: int, z0: float,
                   delay_s: float) -> str:
    """``.subckt NAME p1 ... pN ref`` realising an S model ``exp(-s delay) S_r(s)``:
    the subcircuit ``rational`` (named ``rational_name``, pins p1..pN ref, realising S_r at
    reference impedance ``z0``) behind a matched lossless line (``T``, impedance z0,
    delay/2) at every port. A matched line of delay t at each port multiplies every entry
    of S by exp(-s t) twice (in and out), so S = exp(-s delay) S_r exactly."""
    pins = " ".join(f"p{k + 1}" for k in range(n_ports))
    inner = " ".join(f"d{k + 1}" for k in range(n_ports))
    lines = [rational.strip(), f".subckt {name} {pins} ref",
             f"* common delay {delay_s:.12g} s: matched lossless lines of half of it"]
    for k in range(n_ports):
        lines.append(f"T{k + 1} p{k + 1} ref d{k + 1} ref Z0={z0:.12g} TD={delay_s / 2:.12g}")
    lines += [f"X1 {inner} ref {rational_name}", ".ends"]
    return "\n".join(lines) + "\n"
