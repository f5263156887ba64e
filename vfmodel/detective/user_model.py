"""A user's own network for the detective (``vfmodel diagnose DATASET --model FILE``).

Text format (one statement per line; ``*`` starts a comment line, ``;`` an end-of-line
comment; names are case-sensitive; numbers take SPICE suffixes ``f p n u m k meg g``)::

    * RC ladder whose capacitors may have dielectric loss
    .param rs 50 5 500              ; free parameter: name nominal lower upper
    R1 in n1 {rs}                   ; element whose value is the parameter rs
    C1 n1 0 10n [1n 100n]           ; element value free within [lower upper]
    R2 n1 n2 47                     ; fixed element value
    C2 n2 0 4.7n [0.5n 50n]
    .port Zin in 0                  ; measured impedance between in and 0
    .port Zout n2 0 impedance/out.csv   ; optional file, default impedance/<name>.csv
    .effect insulation_dielectric_loss C1 C2   ; candidate changes and their places
    .effect winding_skin_effect R1
    .effect hertzian_edge_capacitance in:n2
    .effect fixture_inductance Zin
    .end

Elements: ``R``, ``L``, ``C`` (name starts with the letter) between two nodes; node ``0``
is ground. A value is a number (fixed), a number followed by ``[lower upper]`` (a free
parameter named after the element) or ``{name}`` (the ``.param`` of that name). Every
``.port`` is a measured impedance (data: a CSV or Touchstone 1-port file relative to the
dataset directory). Every ``.effect`` line names an effect of the vocabulary and the
places where it may apply (capacitor, resistor, node pair ``a:b`` or port; see
:mod:`vfmodel.detective.candidates`); the detective tries each of them. The starting
network is the netlist as written.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from vfmodel.circuit.mna import MnaSystem
from vfmodel.circuit.netlist import Circuit, Element, NodeSets
from vfmodel.circuit.poles import network_poles
from vfmodel.circuit.spice_import import parse_value
from vfmodel.core.io_spectrum import read_spectrum
from vfmodel.detective.candidates import TRANSFORMS, apply, make_candidate
from vfmodel.detective.noise import spectrum_noise
from vfmodel.detective.problem import Candidate, Channel
from vfmodel.errors import CircuitError, InputError
from vfmodel.greybox.params import ParamSet, ParamSpec

__all__ = ["UserFamily", "UserModel", "parse_user_model", "read_user_model", "user_family"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]
_KIND = {"R": "resistor", "L": "inductor", "C": "capacitor"}


@dataclass(frozen=True)
class UserModel:
    """A parsed user network.

    ``elements``: (name, kind, n1, n2, value, param) with ``param`` the parameter name that
    sets the value (or ``None`` for a fixed value); ``params``: the free parameters;
    ``ports``: (name, n+, n-, file); ``effects``: (effect, place) pairs declared.
    """

    title: str
    elements: tuple[tuple[str, str, str, str, float, str | None], ...]
    params: ParamSet
    ports: tuple[tuple[str, str, str, str], ...]
    effects: tuple[tuple[str, str], ...]


MAX_NODES = 400
"""Largest user network the detective takes (nodes besides ground)."""
MAX_FREE_PARAMS = 120
"""Most free parameters of a user network (each costs a Jacobian column per refit)."""


def _num(tok: str, source: str, where: str, positive: bool = False) -> float:
    try:
        x = parse_value(tok, "")
    except CircuitError:
        raise InputError("not a number", source=source, place=where, found=repr(tok[:40]),
                         expected="a number with an optional SPICE suffix, e.g. 10n") from None
    if not np.isfinite(x):
        raise InputError("value is not finite", source=source, place=where, found=tok[:40],
                         expected="a finite number")
    if positive and x <= 0:
        raise InputError("value must be positive", source=source, place=where,
                         found=tok[:40], expected="a value > 0")
    return x


def parse_user_model(text: str, source: str = "model") -> UserModel:
    """Parse the text format of the module docstring."""
    specs: list[ParamSpec] = []
    elements: list[tuple[str, str, str, str, float, str | None]] = []
    ports: list[tuple[str, str, str, str]] = []
    effects: list[tuple[str, str]] = []
    elem_line: dict[str, int] = {}
    param_line: dict[str, int] = {}
    port_line: dict[str, int] = {}
    title = ""
    for k, raw in enumerate(text.splitlines(), start=1):
        line = raw.split(";", 1)[0].strip()
        where = f"line {k}"
        if not line:
            continue
        if line.startswith("*"):
            title = title or line.lstrip("* ").strip()
            continue
        tok = line.split()
        head = tok[0].lower()
        if head == ".end":
            break
        if head == ".param":
            if len(tok) != 5:
                raise InputError("expected '.param NAME nominal lower upper'", source=source,
                                 place=where, found=line)
            lo, nom, hi = (_num(t, source, where, True) for t in (tok[3], tok[2], tok[4]))
            if tok[1] in param_line:
                raise InputError("parameter defined twice", source=source, place=where,
                                 found=tok[1], expected=f"one .param {tok[1]} (first on "
                                 f"line {param_line[tok[1]]})")
            param_line[tok[1]] = k
            specs.append(_spec(tok[1], nom, lo, hi, source, where))
        elif head == ".port":
            if len(tok) not in (4, 5):
                raise InputError("expected '.port NAME n+ n- [file]'", source=source,
                                 place=where, found=line)
            if tok[2] == tok[3]:
                raise InputError("port between a node and itself", source=source, place=where,
                                 found=line, expected="two different nodes")
            if any(tok[1] == q[0] for q in ports):
                raise InputError("port name used twice", source=source, place=where,
                                 found=tok[1])
            ports.append((tok[1], tok[2], tok[3],
                          tok[4] if len(tok) == 5 else f"impedance/{tok[1]}.csv"))
            port_line[tok[1]] = k
        elif head == ".effect":
            if len(tok) < 3:
                raise InputError("expected '.effect EFFECT PLACE [PLACE ...]'", source=source,
                                 place=where, found=line)
            if tok[1] not in TRANSFORMS:
                raise InputError("effect not available for user networks", source=source,
                                 place=where, found=tok[1],
                                 expected=", ".join(sorted(TRANSFORMS)))
            effects += [(tok[1], t) for t in tok[2:]]
        elif head.startswith("."):
            raise InputError("unknown statement", source=source, place=where, found=tok[0],
                             expected=".param, .port, .effect, .end")
        else:
            letter = tok[0][0].upper()
            if letter not in _KIND:
                raise InputError("unknown element", source=source, place=where,
                                 found=tok[0], expected="R, L or C element")
            m = re.fullmatch(r"(\S+)\s+(\S+)\s+(\S+)\s+(\S+)(?:\s+\[\s*(\S+)\s+(\S+)\s*\])?",
                             line)
            if m is None:
                raise InputError("expected 'NAME n1 n2 value [lower upper]' or "
                                 "'NAME n1 n2 {param}'", source=source, place=where, found=line)
            name, n1, n2, val, lo_s, hi_s = m.groups()
            if name in elem_line:
                raise InputError("element name used twice", source=source, place=where,
                                 found=name, expected=f"unique names (first on line "
                                 f"{elem_line[name]})")
            elem_line[name] = k
            if n1 == n2:
                raise InputError("element between a node and itself", source=source,
                                 place=where, found=line, expected="two different nodes")
            if val.startswith("{") and val.endswith("}"):
                elements.append((name, _KIND[letter], n1, n2, 0.0, val[1:-1]))
            else:
                v = _num(val, source, where, True)
                if lo_s is not None:
                    specs.append(_spec(name, v, _num(lo_s, source, where, True),
                                       _num(hi_s, source, where, True), source, where))
                    elements.append((name, _KIND[letter], n1, n2, v, name))
                else:
                    elements.append((name, _KIND[letter], n1, n2, v, None))
    try:
        params = ParamSet.from_specs(specs)
    except InputError as err:
        raise InputError(f"{source}: {err}") from None
    names = set(params.names)
    for e in elements:
        if e[5] is not None and e[5] not in names:
            raise InputError("element refers to an unknown parameter", source=source,
                             place=e[0], found=e[5])
    if not elements or not ports:
        raise InputError("a model needs elements and at least one .port", source=source)
    enames = {e[0]: e for e in elements}
    pnames = {p[0] for p in ports}
    nodes = {n for e in elements for n in e[2:4]}
    _check_topology(elements, ports, nodes, port_line, elem_line, len(params.names), source)
    for eff, place in effects:
        need = TRANSFORMS[eff].place
        ok = (need in ("capacitor", "resistor") and place in enames
              and enames[place][1] == need) or \
             (need == "port" and place in pnames) or \
             (need == "nodes" and len(place.split(":")) == 2
              and all(n in nodes for n in place.split(":")))
        if not ok:
            raise InputError(f"effect {eff} applies to a {need}", source=source, place=place)
    return UserModel(title or "user model", tuple(elements), params, tuple(ports),
                     tuple(effects))


def _spec(name: str, nominal: float, lower: float, upper: float, source: str,
          where: str) -> ParamSpec:
    if not lower <= nominal <= upper:
        raise InputError("bounds must satisfy lower <= nominal <= upper", source=source,
                         place=where, found=f"{lower:g} {nominal:g} {upper:g}")
    return ParamSpec(name, nominal, lower, upper, "user")


def _check_topology(elements: list[tuple[str, str, str, str, float, str | None]],
                    ports: list[tuple[str, str, str, str]], nodes: set[str],
                    port_line: dict[str, int], elem_line: dict[str, int], n_free: int,
                    source: str) -> None:
    """Ports on existing nodes, no floating sub-network, a size the detective can fit."""
    for name, a, b, _ in ports:
        for n in (a, b):
            if n != "0" and n not in nodes:
                raise InputError("port on a node no element touches", source=source,
                                 place=f"line {port_line[name]}", found=n,
                                 expected="a node of the network or ground 0")
    if len(nodes - {"0"}) > MAX_NODES or n_free > MAX_FREE_PARAMS:
        raise InputError("network too large for the detective", source=source,
                         found=f"{len(nodes - {'0'})} nodes, {n_free} free parameters",
                         expected=f"at most {MAX_NODES} nodes and {MAX_FREE_PARAMS} free "
                         "parameters (each refit costs one network solve per parameter)")
    sets = NodeSets()
    for e in elements:
        sets.union(e[2], e[3])
    ground = sets.find("0")
    for e in elements:
        if sets.find(e[2]) != ground:
            raise InputError("floating sub-network: no path to ground 0", source=source,
                             place=f"line {elem_line[e[0]]}", found=f"element {e[0]}",
                             expected="every element connected to ground 0 through others")


def read_user_model(path: str | Path) -> UserModel:
    """Read and parse a model file."""
    from vfmodel.core.text import read_text_file

    return parse_user_model(read_text_file(Path(path), "model"), str(path))


@dataclass(frozen=True, eq=False)
class UserFamily:
    """Detective family of a :class:`UserModel` and its measured port impedances."""

    model: UserModel
    channels: tuple[Channel, ...]
    band_hz: tuple[float, float]
    _cands: tuple[Candidate, ...] = field(default=())
    # compiled MNA per structure (the applied candidates): a memo, not state
    _mna: dict[tuple[Candidate, ...], MnaSystem] = field(default_factory=dict, repr=False)

    @property
    def name(self) -> str:
        return self.model.title

    def start_params(self) -> ParamSet:
        return self.model.params

    def candidates(self) -> tuple[Candidate, ...]:
        return self._cands

    def free_names(self, applied: Sequence[Candidate], params: ParamSet) -> tuple[str, ...]:
        return tuple(self.model.params.names) + tuple(s.name for c in applied for s in c.params)

    def _elements(self, applied: Sequence[Candidate], params: ParamSet) -> list[Element]:
        vals = params.as_dict()
        els = [Element(n, k, (a, b), vals[p] if p is not None else v)  # type: ignore[arg-type]
               for n, k, a, b, v, p in self.model.elements]
        for c in applied:
            els = apply(els, c, vals)
        return els

    def circuit(self, applied: Sequence[Candidate], params: ParamSet) -> Circuit:
        return Circuit(elements=tuple(self._elements(applied, params)), title=self.name)

    def predict(self, applied: Sequence[Candidate], params: ParamSet) -> list[ArrC]:
        applied = tuple(applied)
        circ = self.circuit(applied, params)
        mna = self._mna.get(applied)
        if mna is None:
            mna = self._mna.setdefault(applied, circ.mna)
        pairs = [(a, b) for _, a, b, _ in self.model.ports]
        out = []
        for i, ((pname, *_), ch) in enumerate(zip(self.model.ports, self.channels, strict=True)):
            z = mna.response(ch.freq_hz, [pairs[i]], [pairs[i]], circ.param_values)[:, 0, 0]
            for c in applied:
                if c.location == pname and TRANSFORMS[c.effect].kind == "series_l":
                    z = z + 2j * np.pi * ch.freq_hz * params[f"{pname}.{c.effect}.L"]
            out.append(z)
        return out

    def poles(self, applied: Sequence[Candidate], params: ParamSet) -> ArrC:
        return network_poles(self.circuit(applied, params))


def user_family(model: UserModel, dataset_dir: str | Path, source: str | None = None,
                allow_outside: bool = False) -> UserFamily:
    """Read the port spectra of ``model`` from ``dataset_dir``, estimate their noise and
    build the candidate list (every declared effect at every declared place).

    Port files must lie inside ``dataset_dir`` (``source``: the model file, for messages)
    unless ``allow_outside``."""
    from vfmodel.core.io_dataset import dataset_file

    root = Path(dataset_dir)
    chans = []
    for name, _, _, rel in model.ports:
        path = dataset_file(root, rel, source or "model", f".port {name}", allow_outside)
        fd = read_spectrum(path).to_kind("Z")
        if fd.values.shape[1:] != (1, 1):
            raise InputError("port spectrum must be a 1-port", source=str(path))
        z = fd.values[:, 0, 0]
        nz = spectrum_noise(fd.freq_hz, z)
        chans.append(Channel(f"impedance:{name}", fd.freq_hz, z,
                             np.full(fd.freq_hz.size, nz.sigma), nz.method,
                             None if nz.blackbox is None else nz.blackbox.poles))
    lo = min(float(c.freq_hz[0]) for c in chans)
    hi = max(float(c.freq_hz[-1]) for c in chans)
    zmax = {n: float(np.abs(c.measured[-1])) for (n, *_), c in
            zip(model.ports, chans, strict=True)}
    vals = model.params.as_dict()
    evals = {e[0]: (vals[e[5]] if e[5] is not None else e[4]) for e in model.elements}
    zs = float(np.median(list(zmax.values())))
    cands = tuple(make_candidate(eff, place, evals.get(place, 1.0), (lo, hi),
                                 zmax.get(place, zs)) for eff, place in model.effects)
    return UserFamily(model, tuple(chans), (lo, hi), cands)
