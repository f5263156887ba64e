"""Synthesis of a :class:`RationalModel` as a :class:`Circuit` (and a SPICE subcircuit).

One-port models use Foster-type branches (the element values follow from matching the
branch immittance to the model term):

* admittance ``Y`` (branches in parallel between port and reference):
  real pole ``r/(s-p)``: series R-L with ``L = 1/r``, ``R = -p/r``;
  complex pair ``r/(s-p) + c.c. = (a1 s + a0)/(s^2 + b1 s + b0)`` with ``a1 = 2 Re r``,
  ``a0 = -2 Re(r conj(p))``, ``b1 = -2 Re p``, ``b0 = |p|^2``: series R-L followed by a
  parallel C||G, whose admittance ``(sC+G)/(LC s^2 + (RC+LG) s + RG+1)`` matches for
  ``L = 1/a1``, ``R = L (b1 - a0 L)``, ``C = 1/(L (b0 - R a0))``, ``G = a0 L C``;
  ``D`` -> conductance, ``E`` -> capacitor.
* impedance ``Z`` (blocks in series): the duals: real pole -> parallel R||C with
  ``C = 1/r``, ``R = -r/p``; complex pair -> C'||G'||(R'-L') with the same formulas
  (L -> C', R -> G', C -> L', G -> R'); ``D`` -> resistor, ``E`` -> inductor.

Multiport models (and any kind "Y", "Z", "S") use the real state-space realisation
``(A, B, C, D, E)`` of :meth:`RationalModel.to_state_space` with controlled sources: each
state is a node with a capacitor ``1/w`` F to ground (``w = |pole|``; the node voltage is
``w x`` so state voltages stay of the order of the port voltages), ``-A_ii/w`` siemens to
ground and VCCS for the off-diagonal ``A`` and for ``B``. Y: the port current is drawn by
VCCS from the state nodes (``C/w``), conductances/VCCS for ``D``, capacitors or a
differentiator (VCVS copy, 1 F capacitor, 0 V sense source, CCCS) for ``E``.
Z: each port is a 0 V sense source in series with a VCVS that copies a summing node
(1 ohm to ground) fed by the states, by ``D`` (CCCS) and by ``E`` (CCCS into a 1 H
inductor); the states are driven by CCCS from the sense sources. S (reference z0): port
= series resistor z0 and a VCVS ``v_m = 2 sqrt(z0) b``; the incident waves
``a = (2 v_p - v_m)/(2 sqrt(z0))`` drive the states.

Foster terms whose peak magnitude is below 1e-12 of the model's are dropped (a fit can
leave such spurious poles; their branches would have absurd values). Element values may
be negative (a non-passive model, or a passive model whose individual
branches are not positive real); the circuit then has ``allow_negative=True``.

References
----------
B. Gustavsen, "Computer code for passivity enforcement of rational macromodels by residue
perturbation", IEEE Trans. Adv. Packag. 30(2), 209-215, 2007 (equivalent-circuit
realisation of pole-residue models). doi:10.1109/TADVP.2007.896018
R. Neumayer, F. Haslinger, A. Stelzer, R. Weigel, "Synthesis of SPICE-compatible
broadband electrical models from n-port scattering parameter data", IEEE Int. Symp. EMC,
2002. doi:10.1109/ISEMC.2002.1032484
"""

from __future__ import annotations

import numpy as np

from vfmodel.circuit.netlist import Circuit
from vfmodel.circuit.spice_export import to_spice
from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import CircuitError

__all__ = ["model_to_spice", "port_nodes", "synthesize"]

_ZERO = 1e-14
_NEGLIGIBLE = 1e-12


def port_nodes(n_ports: int) -> tuple[str, ...]:
    """Port node names ``p1 ... pN`` (the reference is ground ``0``)."""
    return tuple(f"p{k + 1}" for k in range(n_ports))


def synthesize(model: RationalModel, *, form: str = "auto") -> Circuit:
    """A circuit whose port immittance/scattering equals ``model``.

    Parameters
    ----------
    model : RationalModel
        Square (n_out == n_in) model of kind Z, Y or S.
    form : {"auto", "foster", "state_space"}
        ``auto`` = Foster branches for one-port Z and Y, state space otherwise.

    Returns
    -------
    Circuit
        Ports ``p1 ... pN`` to ground ``0`` (``Circuit.ports``), ``allow_negative=True``.
        For Z and S models drive the ports with current sources or through impedances
        (a port is voltage-defined in the state-space form of Z).
    """
    if model.n_in != model.n_out:
        raise CircuitError(f"synthesize: model is {model.n_out}x{model.n_in}; expected a "
                           "square port model")
    if model.kind not in ("Z", "Y", "S"):
        raise CircuitError(f"synthesize: kind {model.kind!r} has no port circuit; expected "
                           "'Z', 'Y' or 'S'")
    if form not in ("auto", "foster", "state_space"):
        raise CircuitError(f"synthesize: form {form!r}; expected auto, foster, state_space")
    one_port = model.n_in == 1 and model.kind in ("Z", "Y")
    if form == "foster" and not one_port:
        raise CircuitError("synthesize: Foster form exists for one-port Z and Y models only")
    if one_port and form != "state_space":
        c = _foster_y(model) if model.kind == "Y" else _foster_z(model)
    else:
        c = _state_space(model)
    for k, p in enumerate(port_nodes(model.n_in)):
        c = c.add_port(f"port{k + 1}", p, "0")
    return c


def model_to_spice(model: RationalModel, name: str = "vfmodel") -> str:
    """``.subckt NAME p1 ... pN ref`` ... ``.ends`` realising ``model`` (CONTRACT, fit)."""
    c = synthesize(model)
    return to_spice(c, subckt=name, pins=port_nodes(model.n_in), ground_pin="ref")


# ---------------------------------------------------------------------- Foster forms
def _pairs(model: RationalModel) -> tuple[list[tuple[float, float]], list[tuple[complex,
                                                                                 complex]]]:
    """Real and complex (upper) pole-residue terms, without negligible ones.

    A term whose largest magnitude over all real frequencies (|r|/|p| for a real pole,
    about |r|/|Re p| for a pair) is below ``_NEGLIGIBLE`` times the model's largest
    magnitude on a grid spanning all poles is dropped: a fit can leave such spurious
    poles, and their Foster branches have absurd element values (e.g. 1e11 F with
    1e-18 H) that ruin the numerics of a simulator.
    """
    real, cplx = [], []
    p = model.poles
    r = model.residues[:, 0, 0]
    w = np.abs(p[np.abs(p) > 0])
    grid = np.logspace(np.log10(w.min()) - 2, np.log10(w.max()) + 2, 400) if w.size else \
        np.array([1.0])
    ref = float(np.max(np.abs(model.evaluate_s(1j * grid)))) + 1e-300
    n_real = int(np.sum(p.imag == 0))
    for k in range(n_real):
        if abs(r[k]) > _NEGLIGIBLE * ref * max(abs(p[k]), 1e-300):
            real.append((float(p[k].real), float(r[k].real)))
    for k in range(n_real, p.size, 2):
        if 2 * abs(r[k]) > _NEGLIGIBLE * ref * max(abs(p[k].real), 1e-300):
            cplx.append((complex(p[k]), complex(r[k])))
    return real, cplx


def _pair_coefs(p: complex, r: complex) -> tuple[float, float, float, float]:
    a1 = 2 * r.real
    a0 = -2 * (r * np.conj(p)).real
    b1 = -2 * p.real
    b0 = abs(p) ** 2
    if abs(a1) <= _ZERO * (abs(a0) / max(abs(p), 1e-300) + abs(r)):
        raise CircuitError(f"synthesize: pole pair {p:.6g} has a purely imaginary residue "
                           f"{r:.6g}; the Foster branch needs Re(r) != 0 "
                           "(use form='state_space')")
    return a1, a0, b1, b0


def _foster_y(model: RationalModel) -> Circuit:
    c = Circuit(title="vfmodel synthesis (Foster, Y)", allow_negative=True)
    port = "p1"
    real, cplx = _pairs(model)
    for k, (p, r) in enumerate(real):
        if r == 0:
            continue
        mid = f"y.real{k}.m"
        c = c.add_resistor(f"y.real{k}.R", port, mid, -p / r) if p != 0 else c
        c = c.add_inductor(f"y.real{k}.L", mid if p != 0 else port, "0", 1.0 / r)
    for k, (pp, rp) in enumerate(cplx):
        a1, a0, b1, b0 = _pair_coefs(pp, rp)
        ll = 1.0 / a1
        rr = ll * (b1 - a0 * ll)
        cc = 1.0 / (ll * (b0 - rr * a0))
        gg = a0 * ll * cc
        n1, n2 = f"y.pair{k}.a", f"y.pair{k}.b"
        if abs(rr) > _ZERO * abs(b1 * ll):
            c = c.add_resistor(f"y.pair{k}.R", port, n1, rr)
        else:
            n1 = port
        c = c.add_inductor(f"y.pair{k}.L", n1, n2, ll)
        c = c.add_capacitor(f"y.pair{k}.C", n2, "0", cc)
        if gg != 0:
            c = c.add_conductance(f"y.pair{k}.G", n2, "0", gg)
    d, e = float(model.dd[0, 0]), float(model.ee[0, 0])
    if d != 0:
        c = c.add_conductance("y.D", port, "0", d)
    if e != 0:
        c = c.add_capacitor("y.E", port, "0", e)
    if len(c) == 0:
        raise CircuitError("synthesize: the model is identically zero")
    return c


def _foster_z(model: RationalModel) -> Circuit:
    c = Circuit(title="vfmodel synthesis (Foster, Z)", allow_negative=True)
    blocks: list[tuple[str, ...]] = []
    real, cplx = _pairs(model)
    for k, (p, r) in enumerate(real):
        if r != 0:
            blocks.append(("real", str(k), repr(p), repr(r)))
    for k, (pp, rp) in enumerate(cplx):
        blocks.append(("pair", str(k), repr(pp), repr(rp)))
    d, e = float(model.dd[0, 0]), float(model.ee[0, 0])
    if d != 0:
        blocks.append(("D",))
    if e != 0:
        blocks.append(("E",))
    if not blocks:
        raise CircuitError("synthesize: a Z model identically zero is a short circuit")
    for i, blk in enumerate(blocks):
        a = "p1" if i == 0 else f"z.n{i}"
        b = "0" if i == len(blocks) - 1 else f"z.n{i + 1}"
        if blk[0] == "real":
            tag, p, r = blk[1], float(blk[2]), float(blk[3])
            c = c.add_capacitor(f"z.real{tag}.C", a, b, 1.0 / r)
            if p != 0:
                c = c.add_resistor(f"z.real{tag}.R", a, b, -r / p)
        elif blk[0] == "pair":
            tag, pc, rc = blk[1], complex(blk[2]), complex(blk[3])
            a1, a0, b1, b0 = _pair_coefs(pc, rc)
            cp = 1.0 / a1
            gp = cp * (b1 - a0 * cp)
            lp = 1.0 / (cp * (b0 - gp * a0))
            rp = a0 * cp * lp
            c = c.add_capacitor(f"z.pair{tag}.C", a, b, cp)
            if abs(gp) > _ZERO * abs(b1 * cp):
                c = c.add_conductance(f"z.pair{tag}.G", a, b, gp)
            if rp != 0:
                mid = f"z.pair{tag}.m"
                c = c.add_resistor(f"z.pair{tag}.R", a, mid, rp)
                c = c.add_inductor(f"z.pair{tag}.L", mid, b, lp)
            else:
                c = c.add_inductor(f"z.pair{tag}.L", a, b, lp)
        elif blk[0] == "D":
            c = c.add_resistor("z.D", a, b, d)
        else:
            c = c.add_inductor("z.E", a, b, e)
    return c


# ---------------------------------------------------------------------- state space
def _state_scales(model: RationalModel) -> np.ndarray:
    """|pole| of the block of each state of ``to_state_space`` (same order)."""
    n_in = model.n_in
    out: list[float] = []
    n_real = int(np.sum(model.poles.imag == 0))
    for k in range(n_real):
        out += [max(abs(model.poles[k]), 1.0)] * n_in
    for k in range(n_real, model.n_poles, 2):
        out += [max(abs(model.poles[k]), 1.0)] * (2 * n_in)
    return np.asarray(out, dtype=float)


def _state_space(model: RationalModel) -> Circuit:
    ss = model.to_state_space()
    n = model.n_in
    kind = model.kind
    w = _state_scales(model)
    ports = port_nodes(n)
    c = Circuit(title=f"vfmodel synthesis (state space, {kind})", allow_negative=True)
    # how inputs u_j control currents: list of (node, weight) terms or a sense source
    sense = [f"ss.sense{j + 1}" for j in range(n)]
    z0 = float(model.z0 or 50.0)
    rz = np.sqrt(z0)
    if kind == "Z":
        for j, p in enumerate(ports):
            c = c.add_vsource(sense[j], p, f"ss.q{j + 1}", 0.0)
    elif kind == "S":
        for j, p in enumerate(ports):
            c = c.add_resistor(f"ss.z0_{j + 1}", p, f"ss.m{j + 1}", z0)

    def drive(c: Circuit, name: str, target: str, j: int, gain: float) -> Circuit:
        """Inject gain * u_j into node ``target`` (from ground)."""
        if gain == 0:
            return c
        if kind == "Y":
            return c.add_vccs(name, "0", target, ports[j], "0", gain)
        if kind == "Z":
            return c.add_cccs(name, "0", target, sense[j], gain)
        # S: a_j = (2 v_p - v_m) / (2 sqrt z0)
        c = c.add_vccs(name + ".p", "0", target, ports[j], "0", gain / rz)
        return c.add_vccs(name + ".m", "0", target, f"ss.m{j + 1}", "0", -gain / (2 * rz))

    nx = ss.a.shape[0]
    xs = [f"ss.x{i + 1}" for i in range(nx)]
    for i in range(nx):
        c = c.add_capacitor(f"ss.x{i + 1}.C", xs[i], "0", 1.0 / w[i])
        c = c.add_conductance(f"ss.x{i + 1}.G", xs[i], "0", -ss.a[i, i] / w[i])
        for jj in np.flatnonzero(ss.a[i]):
            if jj != i:
                c = c.add_vccs(f"ss.x{i + 1}.A{jj + 1}", "0", xs[i], xs[jj], "0",
                               ss.a[i, jj] / w[jj])
        for j in range(n):
            c = drive(c, f"ss.x{i + 1}.B{j + 1}", xs[i], j, float(ss.b[i, j]))
    # outputs
    if kind == "Y":
        for k, p in enumerate(ports):
            for ii in np.flatnonzero(ss.c[k]).tolist():
                c = c.add_vccs(f"ss.y{k + 1}.C{ii + 1}", p, "0", xs[ii], "0",
                               ss.c[k, ii] / w[ii])
            for j in range(n):
                dv, ev = float(ss.d[k, j]), float(ss.e[k, j])
                if j == k:
                    if dv != 0:
                        c = c.add_conductance(f"ss.y{k + 1}.D", p, "0", dv)
                    if ev != 0:
                        c = c.add_capacitor(f"ss.y{k + 1}.E", p, "0", ev)
                    continue
                if dv != 0:
                    c = c.add_vccs(f"ss.y{k + 1}.D{j + 1}", p, "0", ports[j], "0", dv)
                if ev != 0:
                    c = _derivative_source(c, ports[j], j, p, f"ss.y{k + 1}.E{j + 1}", ev)
        return c
    # Z and S: summing node o_k (1 ohm to ground), port voltage copied from it
    for k in range(n):
        o = f"ss.o{k + 1}"
        c = c.add_resistor(f"ss.o{k + 1}.R", o, "0", 1.0)
        for ii in np.flatnonzero(ss.c[k]).tolist():
            c = c.add_vccs(f"ss.o{k + 1}.C{ii + 1}", "0", o, xs[ii], "0", ss.c[k, ii] / w[ii])
        for j in range(n):
            c = drive(c, f"ss.o{k + 1}.D{j + 1}", o, j, float(ss.d[k, j]))
            ev = float(ss.e[k, j])
            if ev != 0:
                if kind != "Z":
                    raise CircuitError("synthesize: an S model with E != 0 is not realisable")
                lnode = f"ss.di{j + 1}"
                if lnode not in c.nodes:
                    c = c.add_cccs(f"ss.di{j + 1}.F", "0", lnode, sense[j], 1.0)
                    c = c.add_inductor(f"ss.di{j + 1}.L", lnode, "0", 1.0)
                c = c.add_vccs(f"ss.o{k + 1}.E{j + 1}", "0", o, lnode, "0", ev)
        if kind == "Z":
            c = c.add_vcvs(f"ss.port{k + 1}.E", f"ss.q{k + 1}", "0", o, "0", 1.0)
        else:
            c = c.add_vcvs(f"ss.port{k + 1}.E", f"ss.m{k + 1}", "0", o, "0", 2 * rz)
    return c


def _derivative_source(c: Circuit, src: str, j: int, port: str, name: str,
                       gain: float) -> Circuit:
    """Draw ``gain * s * v(src)`` from ``port``: VCVS copy, 1 F capacitor, sense, CCCS."""
    copy, mid, sense = f"ss.dv{j + 1}", f"ss.dv{j + 1}.m", f"ss.dv{j + 1}.sense"
    if copy not in c.nodes:
        c = c.add_vcvs(f"ss.dv{j + 1}.E", copy, "0", src, "0", 1.0)
        c = c.add_capacitor(f"ss.dv{j + 1}.C", copy, mid, 1.0)
        c = c.add_vsource(sense, mid, "0", 0.0)
    return c.add_cccs(name, port, "0", sense, gain)
