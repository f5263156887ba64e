"""Substructures of the grey-box PMSM network (reference paper, Figs. 12-17).

Every builder returns a list of :class:`vfmodel.circuit.netlist.Element` between the
given nodes, with hierarchical element names ``prefix.<part>`` and internal nodes
``prefix.<node>``; the assembly concatenates the lists and builds one ``Circuit``.

References
----------
Reference paper (grey-box bearing-voltage model of a 40-kW PMSM), Sec. III: Fig. 13
(insulation / air gap), Fig. 14 (RL ladder for the skin effect), Figs. 15-16 (bearing,
Hertzian contact, lubricant layers, metallic-contact switch).
"""

from __future__ import annotations

from vfmodel.circuit.netlist import Element
from vfmodel.errors import InputError

__all__ = [
    "bearing",
    "capacitor",
    "inductor",
    "insulation",
    "ladder_values",
    "lubricant_film",
    "rc_layer",
    "resistor",
    "rl_branch",
    "rl_ladder",
    "rl_plain",
    "winding_section",
]


def resistor(name: str, a: str, b: str, r: float) -> Element:
    return Element(name, "resistor", (a, b), float(r))


def inductor(name: str, a: str, b: str, l_h: float) -> Element:
    return Element(name, "inductor", (a, b), float(l_h))


def capacitor(name: str, a: str, b: str, c: float) -> Element:
    return Element(name, "capacitor", (a, b), float(c))


def ladder_values(r_dc: float, l_int: float, rho: float,
                  n_rungs: int) -> tuple[list[float], list[float]]:
    """Rung values ``R_k = r_dc rho^k``, ``L_k = l_int / rho^k``, k = 0..n_rungs-1.

    With ``rho > 1`` every deeper rung is more resistive and less inductive: the current
    moves to the outer (low-L, high-R) rungs as the frequency rises, which is the skin
    effect (resistance ~ sqrt(f) over the band spanned by the rungs' corner frequencies
    ``R_{k+1} / (2 pi L_k)``, which are spaced by ``rho^2``).
    """
    if n_rungs < 1:
        raise InputError("RL ladder needs at least one rung", found=str(n_rungs))
    if not rho > 1:
        raise InputError("RL ladder ratio rho must be > 1", found=repr(rho))
    return ([r_dc * rho**k for k in range(n_rungs)], [l_int / rho**k for k in range(n_rungs)])


def rl_ladder(prefix: str, a: str, b: str, *, r_dc: float, l_ext: float, l_int: float,
              rho: float, n_rungs: int) -> list[Element]:
    """RL ladder (Fig. 14) between ``a`` and ``b``.

    ``a -L_ext- a1 -R_0- n1``; rung k (k = 0..n-1): ``n_{k+1} -L_k- b``; between rungs
    ``n_{k+1} -R_{k+1}- n_{k+2}``. Impedance
    ``Z = jw L_ext + R_0 + (jw L_0 || (R_1 + (jw L_1 || (R_2 + ...))))``: at DC ``r_dc`` and
    ``l_ext + l_int`` (to first order), at high frequency ``sum R_k`` and ``l_ext + L_{n-1}``.
    """
    rs, ls = ladder_values(r_dc, l_int, rho, n_rungs)
    els: list[Element] = []
    start = a
    if l_ext > 0:
        els.append(inductor(f"{prefix}.L_ext", a, f"{prefix}.a1", l_ext))
        start = f"{prefix}.a1"
    els.append(resistor(f"{prefix}.R0", start, f"{prefix}.n1", rs[0]))
    for k in range(n_rungs):
        node = f"{prefix}.n{k + 1}"
        els.append(inductor(f"{prefix}.L{k}", node, b, ls[k]))
        if k + 1 < n_rungs:
            els.append(resistor(f"{prefix}.R{k + 1}", node, f"{prefix}.n{k + 2}", rs[k + 1]))
    return els


def rl_plain(prefix: str, a: str, b: str, *, r: float, l_h: float) -> list[Element]:
    """Plain series ``a -R- m -L- b`` (the ladder without skin effect)."""
    return [resistor(f"{prefix}.R", a, f"{prefix}.m", r),
            inductor(f"{prefix}.L", f"{prefix}.m", b, l_h)]


def rl_branch(prefix: str, a: str, b: str, *, skin: bool, r_dc: float, l_ext: float,
              l_int: float, rho: float, n_rungs: int) -> list[Element]:
    """:func:`rl_ladder` when ``skin`` else :func:`rl_plain` with ``R = r_dc``,
    ``L = l_ext + l_int`` (same DC resistance and low-frequency inductance)."""
    if skin:
        return rl_ladder(prefix, a, b, r_dc=r_dc, l_ext=l_ext, l_int=l_int, rho=rho,
                         n_rungs=n_rungs)
    return rl_plain(prefix, a, b, r=r_dc, l_h=l_ext + l_int)


def insulation(prefix: str, a: str, b: str, *, c: float, r_ins: float, loss: bool,
               k_d: float = 0.1, tau_d: float = 1e-6) -> list[Element]:
    """Insulation layer / air gap (Fig. 13): ``R_ins || C || (R_d + C_d)``.

    The dielectric-loss branch (``loss``) has ``C_d = k_d C`` and ``R_d = tau_d / C_d``:
    the capacitance is ``C (1 + k_d)`` well below ``1 / (2 pi tau_d)`` and ``C`` above, with
    a loss peak at the relaxation frequency (Debye relaxation).
    """
    els = [resistor(f"{prefix}.R", a, b, r_ins), capacitor(f"{prefix}.C", a, b, c)]
    if loss:
        c_d = k_d * c
        els += [resistor(f"{prefix}.R_d", a, f"{prefix}.d", tau_d / c_d),
                capacitor(f"{prefix}.C_d", f"{prefix}.d", b, c_d)]
    return els


def rc_layer(prefix: str, a: str, b: str, *, r: float, c: float, loss: bool,
             k_d: float = 0.1, tau_d: float = 1e-6) -> list[Element]:
    """One lubricant layer: three-branch parallel RC (same structure as :func:`insulation`)."""
    return insulation(prefix, a, b, c=c, r_ins=r, loss=loss, k_d=k_d, tau_d=tau_d)


def lubricant_film(prefix: str, a: str, b: str, *, r_1: float, c_1: float, two_layer: bool,
                   r_2: float = 1.0, c_2: float = 1e-7, loss: bool = False,
                   k_d: float = 0.1, tau_d: float = 1e-6) -> list[Element]:
    """Lubricant film between ``a`` and ``b``: the base-oil layer ``oil`` and, with
    ``two_layer``, the thickener-rich layer ``thickener`` in series (Figs. 16-17).

    The dielectric-loss branch (``loss``) is added to the base-oil layer.
    """
    if not two_layer:
        return rc_layer(f"{prefix}.oil", a, b, r=r_1, c=c_1, loss=loss, k_d=k_d, tau_d=tau_d)
    mid = f"{prefix}.m"
    return (rc_layer(f"{prefix}.oil", a, mid, r=r_1, c=c_1, loss=loss, k_d=k_d, tau_d=tau_d)
            + rc_layer(f"{prefix}.thickener", mid, b, r=r_2, c=c_2, loss=False))


def winding_section(prefix: str, a: str, b: str, *, r: float, l_h: float, r_p: float,
                    c_s: float, skin: bool, l_frac: float = 0.05, rho: float = 4.0,
                    n_rungs: int = 3) -> list[Element]:
    """Winding section: series R-L (ladder with ``skin``) with ``R_p`` (iron/eddy loss
    damping) and ``C_s`` (inter-turn capacitance) across it.

    With ``skin`` the ladder has ``l_int = l_frac L`` and ``l_ext = (1 - l_frac) L`` so the
    low-frequency inductance stays ``L``.
    """
    els = rl_branch(f"{prefix}.rl", a, b, skin=skin, r_dc=r, l_ext=(1 - l_frac) * l_h,
                    l_int=l_frac * l_h, rho=rho, n_rungs=n_rungs)
    els += [resistor(f"{prefix}.R_p", a, b, r_p), capacitor(f"{prefix}.C_s", a, b, c_s)]
    return els


def bearing(prefix: str, s: str, f: str, *, c_air: float, ball_r: float, ball_l_ext: float,
            ball_l_int: float, ball_rho: float, ball_skin: bool, r_h: float,
            r_1: float = 1e5, c_1: float = 1e-8,
            two_layer: bool = False, r_2: float = 1.0, c_2: float = 1e-7,
            lub_loss: bool = False, k_d: float = 0.1, tau_d: float = 1e-6,
            edge: bool = False, c_edge: float = 1e-9, metallic: bool = False,
            closed: bool = False, n_rungs: int = 3) -> list[Element]:
    """Rolling bearing between shaft node ``s`` and frame node ``f`` (Figs. 15-16).

    ``C_air`` across ``s``-``f``; central branch ``s -[ball]- X -R_h- Y -[film]- f``; with
    ``metallic`` a switch ``X``-``f`` (closed = metallic contact); with ``edge`` the edge
    capacitance ``X``-``f``. Node names: ``prefix.X``, ``prefix.Y``.
    """
    x, y = f"{prefix}.X", f"{prefix}.Y"
    els = [capacitor(f"{prefix}.C_air", s, f, c_air)]
    els += rl_branch(f"{prefix}.ball", s, x, skin=ball_skin, r_dc=ball_r, l_ext=ball_l_ext,
                     l_int=ball_l_int, rho=ball_rho, n_rungs=n_rungs)
    els.append(resistor(f"{prefix}.R_h", x, y, r_h))
    els += lubricant_film(f"{prefix}.lubricant", y, f, r_1=r_1, c_1=c_1, two_layer=two_layer,
                          r_2=r_2, c_2=c_2, loss=lub_loss, k_d=k_d, tau_d=tau_d)
    if edge:
        els.append(capacitor(f"{prefix}.C_edge", x, f, c_edge))
    if metallic:
        els.append(Element(f"{prefix}.contact", "switch", (x, f), 0.0, closed=closed))
    return els
