"""Import a flat SPICE netlist (the R, L, C, K, V, I subset, plus E, G, F, H) as a Circuit.

The first line is the title. Continuation lines (``+``), comments (``*`` lines, inline
``;`` and ``$``) and SPICE number suffixes (``f p n u m k meg g t mil``, case-insensitive,
trailing unit letters ignored: ``10pF``) are understood. Sources take their ``AC``
amplitude (0 without an ``AC`` field; a non-zero AC phase is refused); DC values and
transient functions are ignored. Analysis and option cards and ``.control`` blocks are
skipped; ``.subckt``, ``.include``, ``.model``/semiconductor devices and subcircuit
instances (``X``) are refused with a :class:`vfmodel.errors.CircuitError` naming the line.
Mapping comments written by :func:`vfmodel.circuit.spice_export.to_spice` restore the
original hierarchical names, conductances, switches and node names.
"""

from __future__ import annotations

import re

from vfmodel.circuit.netlist import Circuit, Element, check_value
from vfmodel.errors import CircuitError

_SUFFIX = {"t": 1e12, "g": 1e9, "meg": 1e6, "k": 1e3, "mil": 25.4e-6, "m": 1e-3,
           "u": 1e-6, "n": 1e-9, "p": 1e-12, "f": 1e-15}
_NUM = re.compile(r"^([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)(meg|mil|[tgkmunpf])?[a-z]*$",
                  re.IGNORECASE)


_SKIPPED_CARDS = frozenset(
    ".tran .ac .dc .op .tf .noise .pz .sens .four .disto .option .options .opt .print .plot "
    ".probe .save .meas .measure .temp .global .title .ic .nodeset .width .csparam".split())
"""Analysis, output and option cards: skipped (the network is all that is imported)."""


def parse_value(token: str, where: str = "") -> float:
    """A SPICE number with optional scale suffix (``1.5k``, ``10pF``, ``2meg``)."""
    m = _NUM.match(token.strip())
    if not m:
        raise CircuitError(f"{where}: {token!r} is not a SPICE number")
    x = float(m.group(1))
    suf = (m.group(2) or "").lower()
    return x * _SUFFIX.get(suf, 1.0)


def _logical_lines(text: str) -> list[tuple[int, str]]:
    out: list[tuple[int, str]] = []
    for k, raw in enumerate(text.splitlines(), start=1):
        line = raw.rstrip()
        if k == 1:
            out.append((k, line))
            continue
        stripped = line.strip()
        if stripped.startswith("+") and out:
            kk, prev = out[-1]
            out[-1] = (kk, prev + " " + stripped[1:])
            continue
        out.append((k, line))
    return out


def from_spice(text: str, *, source: str = "netlist", allow_negative: bool = False) -> Circuit:
    """Parse netlist ``text`` into a :class:`Circuit` (see the module docstring)."""
    lines = _logical_lines(text)
    if not lines:
        raise CircuitError(f"{source}: empty netlist")
    title = lines[0][1].strip() or "imported"
    names: dict[str, tuple[str, str]] = {}        # spice name (lower) -> (kind, original)
    node_names: dict[str, str] = {}
    open_switches: list[tuple[str, str, str]] = []
    cards: list[tuple[int, list[str]]] = []
    in_control = False
    for lineno, line in lines[1:]:
        s = line.strip()
        if not s:
            continue
        if s.startswith("*"):
            parts = s[1:].split()
            if parts[:1] == ["vfmodel:"] and len(parts) >= 4:
                names[parts[1].lower()] = (parts[2], parts[3])
            elif parts[:1] == ["vfmodel-node:"] and len(parts) >= 3:
                node_names[parts[1].lower()] = parts[2]
            elif parts[:1] == ["vfmodel-open-switch:"] and len(parts) >= 5:
                open_switches.append((parts[2], parts[3], parts[4]))
            continue
        s = re.split(r"\s[;$]|^;", s)[0].strip()
        low = s.lower()
        if in_control:
            in_control = not low.startswith(".endc")
            continue
        if low.startswith(".control"):
            in_control = True
            continue
        if low.startswith(".end") and not low.startswith(".ends"):
            break
        if low.startswith((".subckt", ".ends", ".include", ".inc", ".lib", ".model", ".param")):
            raise CircuitError(f"{source}, line {lineno}: {s.split()[0]!r} is not supported "
                               "(flat R/L/C/K/V/I/E/G/F/H netlists only)")
        if low.startswith("."):
            if low.split()[0] not in _SKIPPED_CARDS:
                raise CircuitError(f"{source}, line {lineno}: unknown card {s.split()[0]!r} "
                                   "(expected elements, analysis/option cards or .end)")
            continue
        cards.append((lineno, s.split()))

    def node(tok: str) -> str:
        t = tok.lower()
        if t in ("0", "gnd"):
            return "0"
        return node_names.get(t, tok)

    elements: list[Element] = []
    spice_to_name = {
        tok[0].lower(): (names[tok[0].lower()][1] if tok[0].lower() in names else tok[0])
        for _, tok in cards
    }
    first_line: dict[str, int] = {}
    for lineno, tok in cards:
        where = f"{source}, line {lineno}"
        sname = tok[0]
        letter = sname[0].upper()
        kind_orig = names.get(sname.lower())
        name = spice_to_name[sname.lower()]
        if sname.lower() in first_line:
            raise CircuitError(f"{where}: element name {sname!r} is used twice (first on line "
                               f"{first_line[sname.lower()]}; expected unique names)")
        first_line[sname.lower()] = lineno
        try:
            el = _element(letter, tok, name, kind_orig[0] if kind_orig else None, node, where,
                          spice_to_name)
        except IndexError:
            raise CircuitError(f"{where}: card {' '.join(tok)!r} has too few fields") from None
        try:
            check_value(el, el.value, allow_negative)
        except CircuitError as err:
            raise CircuitError(f"{where}: {err}") from None
        if letter in "RLCVIEGFH" and el.nodes[:2] and el.nodes[0] == el.nodes[1]:
            raise CircuitError(f"{where}: element {sname!r} has both terminals on node "
                               f"{el.nodes[0]!r} (expected two different nodes)")
        elements.append(el)
    for orig, n1, n2 in open_switches:
        elements.append(Element(orig, "switch", (node(n1), node(n2)), 0.0, closed=False))
    return Circuit(elements=tuple(elements), title=title, allow_negative=allow_negative)


def _element(letter: str, tok: list[str], name: str, kind: str | None, node: object,
             where: str, spice_to_name: dict[str, str]) -> Element:
    assert callable(node)
    if letter in "RLC":
        n1, n2 = node(tok[1]), node(tok[2])
        val_tok = tok[3].split("=")[-1]
        v = parse_value(val_tok, where)
        if letter == "R" and kind == "conductance":
            return Element(name, "conductance", (n1, n2), 1.0 / v)
        k = {"R": "resistor", "L": "inductor", "C": "capacitor"}[letter]
        return Element(name, k, (n1, n2), v)  # type: ignore[arg-type]
    if letter == "K":
        l1 = spice_to_name.get(tok[1].lower())
        l2 = spice_to_name.get(tok[2].lower())
        if l1 is None or l2 is None:
            raise CircuitError(f"{where}: coupling {tok[0]!r} refers to inductors not in "
                               "the netlist")
        return Element(name, "mutual", (), parse_value(tok[3], where), refs=(l1, l2))
    if letter in "VI":
        n1, n2 = node(tok[1]), node(tok[2])
        ac = 0.0
        rest = [t.lower() for t in tok[3:]]
        if "ac" in rest:
            i = rest.index("ac")
            if i + 1 < len(rest) and _NUM.match(rest[i + 1]):
                ac = parse_value(rest[i + 1], where)
                if i + 2 < len(rest) and _NUM.match(rest[i + 2]) and \
                        parse_value(rest[i + 2], where) != 0.0:
                    raise CircuitError(f"{where}: AC phase other than 0 is not supported")
            else:
                ac = 1.0
        if letter == "V" and kind == "switch":
            return Element(name, "switch", (n1, n2), 0.0, closed=True)
        return Element(name, "vsource" if letter == "V" else "isource", (n1, n2), ac)
    if letter in "EG":
        nodes = tuple(node(t) for t in tok[1:5])
        return Element(name, "vcvs" if letter == "E" else "vccs", nodes,
                       parse_value(tok[5], where))
    if letter in "FH":
        ctrl = spice_to_name.get(tok[3].lower(), tok[3])
        return Element(name, "cccs" if letter == "F" else "ccvs", (node(tok[1]), node(tok[2])),
                       parse_value(tok[4], where), refs=(ctrl,))
    raise CircuitError(f"{where}: element {tok[0]!r} is not supported (expected R, L, C, K, V, "
                       "I, E, G, F or H)")
