"""Independent virtual motor benches: structurally unlike the grey-box model (issue 19).

What differs from the grey-box network of :mod:`vfmodel.greybox.assembly` (and from the
project's own bench :mod:`benches.truth`), each drawn per seed:

- winding: 5-8 coils per phase, each an RL ladder of 5 rungs with its own loss and
  inter-turn capacitance, per-coil asymmetry; the winding-frame and winding-rotor
  capacitances spread unevenly over the coil junctions; end-winding phase-to-phase and
  star-point-to-frame capacitances;
- insulation and air gap with two Debye relaxations (the model has one);
- rotor with two nodes (NDE and DE half) joined by a shaft ladder, the air gap split over
  both halves; frame with a drive-end and a non-drive-end node;
- a bearing at each shaft end (drive end and non-drive end, different sizes), each with an
  inner-race and an outer-race contact in series through the ball ladder; every contact
  has a base-oil film in series with a conducting thickener-rich layer whose share of the
  film grows with speed (oil bleeding), an edge capacitance, and at standstill a metallic
  contact resistance across the films;
- film thickness following a Hamrock-Dowson-like law ``h ~ n^0.67`` with drawn exponents;
- a three-section pi cable between inverter and terminals (with skin-effect damping);
- PWM with period-to-period duty jitter and raised-cosine (S-shaped) edges: the records
  are segments of a longer run and are not periodic;
- probes of 25 MHz-class bandwidth that differ per channel (2nd-order terminals,
  1st-order bearing probe with a small skew), white noise and EMI at 14-37 MHz.

Everything is pure computation; :func:`write_bench` writes a dataset (CONTRACT section 2)
plus ``truth.json`` with the equivalent quantities the grey-box model can be compared
with (:func:`equivalents`).

With ``extra=True`` (``make_independent_bench.py --extra-measurements``) it also writes the
further measurements of CONTRACT section 2a, computed from the same circuit: the
``Shaft-Frame`` impedance (NDE shaft end to frame, terminals open) at standstill and at
every rotating speed, and the recording channels ``u_B_DE`` (drive-end shaft end ``SD`` to
frame, through its own first-order probe) and ``i_CM`` (sum of the three phase currents
entering the machine terminals, through a first-order current probe), with their own
noise. Their random draws come from streams of their own, so the bench without the flag
is unchanged byte for byte and the four paper channels are the same with it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from vfmodel.circuit.netlist import Circuit, Element
from vfmodel.core.atomic import atomic_directory
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.io_spectrum import csv_text
from vfmodel.greybox.metrics import spectral_corr, spectral_corr_periodogram
from vfmodel.signals.filters import brickwall_filter

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]
PHASES = ("U", "V", "W")
TOPOLOGY_PORTS: dict[str, tuple[str, str]] = {
    "U-Frame": ("U", "0"), "V-Frame": ("V", "0"), "W-Frame": ("W", "0"),
    "U-V": ("U", "V"), "V-W": ("V", "W"), "W-U": ("W", "U"),
}
INV = ("inv.U", "inv.V", "inv.W")
SPEEDS = (0.0, 100.0, 200.0, 300.0, 400.0, 500.0)
SHAFT_FRAME = ("SN", "0")
"""Node pair of the ``Shaft-Frame`` topology (CONTRACT section 2a)."""
EXTRA_OUTPUTS = ("SD", *(f"i(cab.{ph}.L2)" for ph in PHASES))
"""Drive-end shaft end and the current of each cable's last series inductor."""


def _ln(rng: np.random.Generator, nominal: float, sigma: float) -> float:
    return float(nominal * np.exp(sigma * rng.standard_normal()))


@dataclass(frozen=True)
class Draw:
    """All drawn values of one bench (``v``: named floats; structure integers)."""

    seed: int
    v: dict[str, float]
    n_coils: int
    coil_asym: ArrF          # (3, n_coils, 4)
    junction_w: ArrF         # (3, n_coils - 1) weights of the distributed capacitances
    fs_hz: float
    n_freq: int
    f_min_hz: float


def draw(seed: int) -> Draw:
    """Drawn machine, bearing, inverter and acquisition values of bench ``seed``."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 1919]))
    s = 0.25
    v: dict[str, float] = {
        "L_w": _ln(rng, 5e-4, s), "R_w": _ln(rng, 0.03, s), "R_p": _ln(rng, 1.5e3, s),
        "C_s": _ln(rng, 30e-12, s), "C_t": _ln(rng, 150e-12, s),
        "C_wf": _ln(rng, 1.2e-9, s), "C_wr": _ln(rng, 212e-12, 0.3),
        "C_rf": _ln(rng, 1.3e-9, 0.3), "rf_split": float(rng.uniform(0.35, 0.65)),
        "wr_split": float(rng.uniform(0.35, 0.65)),
        "C_pp": _ln(rng, 15e-12, s), "C_nf": _ln(rng, 40e-12, s),
        "skin_frac": float(rng.uniform(0.05, 0.2)), "skin_rho": float(rng.uniform(3, 7)),
        "R_ins": _ln(rng, 1e8, 0.5),
        "k1": float(rng.uniform(0.03, 0.12)), "tau1": _ln(rng, 3e-7, 0.5),
        "k2": float(rng.uniform(0.02, 0.08)), "tau2": _ln(rng, 2e-5, 0.5),
        "frame_R": _ln(rng, 1e-3, s), "frame_L": _ln(rng, 6e-9, s),
        "frame_seg_L": _ln(rng, 2e-9, s),
        "shaft_R": _ln(rng, 1e-3, s), "shaft_L_N": _ln(rng, 20e-9, s),
        "shaft_L_D": _ln(rng, 25e-9, s), "shaft_L_mid": _ln(rng, 10e-9, s),
        "ball_R": _ln(rng, 5e-3, s), "ball_L": _ln(rng, 20e-9, s),
        "C_air": _ln(rng, 100e-12, s),
        # one contact's base-oil film at 100 rpm (NDE, inner race); the others scale
        "C_oil100": _ln(rng, 45e-9, 0.3), "R_oil100": _ln(rng, 1.5e5, 0.5),
        "eps_ratio": float(rng.uniform(1.5, 3.0)),           # thickener / oil permittivity
        # thickener / oil resistivity: the thickener layer's RC corner (rho eps) from
        # ~10 kHz to ~1 MHz, i.e. anywhere from the plateau band to the ringing band
        "rho_ratio": float(10 ** rng.uniform(-5.3, -3.0)),
        "share0": float(rng.uniform(0.05, 0.15)),            # thickener share at 100 rpm
        "share_slope": float(rng.uniform(0.05, 0.10)),       # per 100 rpm
        "h_exp": float(rng.uniform(0.55, 0.75)),             # film thickness ~ n^h_exp
        "r_exp": float(rng.uniform(0.6, 1.2)),               # extra resistivity rise
        "C_edge": _ln(rng, 0.8e-9, 0.3), "R_h": _ln(rng, 0.3, 0.5),
        "area_in": float(rng.uniform(0.6, 0.85)), "area_out": float(rng.uniform(1.1, 1.4)),
        "de_size": float(rng.uniform(1.1, 1.6)),             # DE bearing larger
        "standstill_film": float(rng.uniform(1.5, 2.5)),     # film C factor at 0 rpm
        "R_contact": _ln(rng, 0.3, 0.5),                     # metallic contact at 0 rpm
        # cable (per section of three) and inverter
        "cab_R": _ln(rng, 0.02, s), "cab_L": _ln(rng, 0.12e-6, s),
        "cab_Ld": _ln(rng, 1.0e-6, s), "cab_Rd": _ln(rng, 12.0, s),
        "cab_C": _ln(rng, 0.35e-9, s),
        "v_dc": float(rng.uniform(250, 320)), "t_rise": float(rng.uniform(40e-9, 60e-9)),
        "t_fall": float(rng.uniform(20e-9, 35e-9)), "jitter": float(rng.uniform(0.01, 0.03)),
        "m0": float(rng.uniform(0.05, 0.12)), "m_per_rpm": float(rng.uniform(3e-4, 7e-4)),
        "theta0": float(rng.uniform(0, 2 * np.pi)),
        "probe_bw_U": float(rng.uniform(22e6, 28e6)), "probe_bw_V": float(rng.uniform(22e6, 28e6)),
        "probe_bw_W": float(rng.uniform(22e6, 28e6)), "probe_bw_B": float(rng.uniform(22e6, 28e6)),
        "skew_B": float(rng.uniform(-0.5e-9, 0.5e-9)),
        "snr_terminal_db": float(rng.uniform(33, 37)), "snr_b0_db": float(rng.uniform(0.5, 2.0)),
        "z_noise": float(rng.uniform(0.003, 0.007)),
    }
    n_coils = int(rng.integers(5, 9))
    asym = np.exp(0.06 * rng.standard_normal((3, n_coils, 4)))
    jw = np.exp(0.3 * rng.standard_normal((3, n_coils - 1)))
    jw /= jw.sum(axis=1, keepdims=True)
    fs = float(rng.choice([62.5e6, 100e6, 125e6]))
    n_freq = int(rng.choice([301, 401, 801]))
    f_min = float(rng.choice([1e3, 1e3, 2e3]))
    return Draw(seed, v, n_coils, asym, jw, fs, n_freq, f_min)


def draw_extra(seed: int) -> dict[str, float]:
    """Acquisition of the further channels of bench ``seed`` (a stream of its own)."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 1920]))
    return {"probe_bw_B_DE": float(rng.uniform(22e6, 28e6)),
            "skew_B_DE": float(rng.uniform(-0.5e-9, 0.5e-9)),
            "probe_bw_I": float(rng.uniform(20e6, 40e6)),
            "snr_i_cm_db": float(rng.uniform(25, 35))}


# ------------------------------------------------------------------------- network
def _r(n: str, a: str, b: str, x: float) -> Element:
    return Element(n, "resistor", (a, b), float(x))


def _l(n: str, a: str, b: str, x: float) -> Element:
    return Element(n, "inductor", (a, b), float(x))


def _c(n: str, a: str, b: str, x: float) -> Element:
    return Element(n, "capacitor", (a, b), float(x))


def _ladder(p: str, a: str, b: str, r_dc: float, l_tot: float, frac: float, rho: float,
            n: int = 5) -> list[Element]:
    """RL ladder with ``n`` rungs (external inductance ``(1-frac) l_tot``)."""
    els = [_l(f"{p}.Le", a, f"{p}.a", (1 - frac) * l_tot), _r(f"{p}.R0", f"{p}.a", f"{p}.n1", r_dc)]
    li = frac * l_tot
    for k in range(n):
        node = f"{p}.n{k + 1}"
        els.append(_l(f"{p}.L{k}", node, b, li / rho**k))
        if k + 1 < n:
            els.append(_r(f"{p}.R{k + 1}", node, f"{p}.n{k + 2}", r_dc * rho ** (k + 1)))
    return els


def _dielectric(p: str, a: str, b: str, c: float, d: Draw) -> list[Element]:
    """``R_ins || C`` with two Debye branches."""
    v = d.v
    els = [_r(f"{p}.R", a, b, v["R_ins"]), _c(f"{p}.C", a, b, c)]
    for k, (kk, tau) in enumerate(((v["k1"], v["tau1"]), (v["k2"], v["tau2"]))):
        cd = kk * c
        els += [_r(f"{p}.Rd{k}", a, f"{p}.d{k}", tau / cd), _c(f"{p}.Cd{k}", f"{p}.d{k}", b, cd)]
    return els


def film_values(d: Draw, speed_rpm: float, size: float, area: float) -> dict[str, float]:
    """Base-oil and thickener layer of one contact (``size``: bearing, ``area``: race)."""
    v = d.v
    a = size * area
    if speed_rpm <= 0:
        c_oil = v["C_oil100"] * a * v["standstill_film"]
        r_oil = v["R_oil100"] * a ** -1 / v["standstill_film"]
        share = v["share0"] * 0.5
    else:
        x = speed_rpm / 100.0
        h = x ** v["h_exp"]
        share = min(0.6, v["share0"] + v["share_slope"] * (x - 1))
        c_oil = v["C_oil100"] * a / h
        r_oil = v["R_oil100"] / a * h * x ** v["r_exp"]
    # layers of one film of thickness h: oil (1 - s) h, thickener s h (share s)
    c_o = c_oil / (1 - share)
    r_o = r_oil * (1 - share)
    c_t = c_oil * v["eps_ratio"] / max(share, 1e-3)
    r_t = r_oil * v["rho_ratio"] * share
    return {"C_oil": c_o, "R_oil": r_o, "C_th": c_t, "R_th": r_t, "share": share}


def _contact(p: str, a: str, b: str, d: Draw, speed: float, size: float,
             area: float) -> list[Element]:
    fv = film_values(d, speed, size, area)
    m, n = f"{p}.m", f"{p}.n"
    els = [_r(f"{p}.Rh", a, m, d.v["R_h"] / (size * area)),
           _r(f"{p}.Ro", m, f"{p}.o", fv["R_oil"]), _c(f"{p}.Co", m, f"{p}.o", fv["C_oil"]),
           _r(f"{p}.Rt", f"{p}.o", n, fv["R_th"]), _c(f"{p}.Ct", f"{p}.o", n, fv["C_th"]),
           _l(f"{p}.Lc", n, b, 1e-9),
           _c(f"{p}.Ce", a, b, d.v["C_edge"] * size * area)]
    if speed <= 0:
        els.append(_r(f"{p}.Rmc", m, n, d.v["R_contact"] / (size * area)))
    return els


def _bearing(p: str, s: str, f: str, d: Draw, speed: float, size: float) -> list[Element]:
    v = d.v
    els = [_c(f"{p}.Cair", s, f, v["C_air"] * size)]
    els += _contact(f"{p}.inner", s, f"{p}.bi", d, speed, size, v["area_in"])
    els += _ladder(f"{p}.ball", f"{p}.bi", f"{p}.bo", v["ball_R"] / size, v["ball_L"] / size,
                   0.3, 4.0)
    els += _contact(f"{p}.outer", f"{p}.bo", f, d, speed, size, v["area_out"])
    return els


def machine(d: Draw, speed_rpm: float) -> Circuit:
    """Machine network: terminals U V W, frame 0, NDE shaft end SN."""
    v = d.v
    nc = d.n_coils
    els: list[Element] = []
    rotor = ("RN", "RD")
    for i, ph in enumerate(PHASES):
        nodes = [ph] + [f"{ph}.j{k}" for k in range(1, nc)] + ["N"]
        a = d.coil_asym[i]
        for k in range(nc):
            pre = f"w.{ph}.{k}"
            els += _ladder(f"{pre}.rl", nodes[k], nodes[k + 1], v["R_w"] / nc * a[k, 0],
                           v["L_w"] / nc * a[k, 0], v["skin_frac"], v["skin_rho"])
            els += [_r(f"{pre}.Rp", nodes[k], nodes[k + 1], 2 * v["R_p"] / nc * a[k, 1]),
                    _c(f"{pre}.Cs", nodes[k], nodes[k + 1], nc * v["C_s"] / 2 * a[k, 2])]
        els.append(_c(f"w.{ph}.Ct", ph, "F", v["C_t"] * a[0, 3]))
        for k, node in enumerate(nodes[1:-1]):
            wk = d.junction_w[i, k]
            els += _dielectric(f"ins.wf.{ph}.{k}", node, "F", v["C_wf"] * wk, d)
            # winding-rotor coupling split over the two rotor halves
            els += _dielectric(f"ins.wrN.{ph}.{k}", node, "RN", v["C_wr"] * wk * v["wr_split"], d)
            els += _dielectric(f"ins.wrD.{ph}.{k}", node, "RD",
                               v["C_wr"] * wk * (1 - v["wr_split"]), d)
    for a_, b_ in (("U", "V"), ("V", "W"), ("W", "U")):
        els.append(_c(f"ew.{a_}{b_}", a_, b_, v["C_pp"]))
    els.append(_c("ew.N", "N", "F", v["C_nf"]))
    els += _dielectric("gap.N", "RN", "F", v["C_rf"] * v["rf_split"], d)
    els += _dielectric("gap.D", "RD", "F", v["C_rf"] * (1 - v["rf_split"]), d)
    els += _ladder("frame", "F", "0", v["frame_R"], v["frame_L"], 0.15, 4.0)
    els += [_l("frame.N", "F", "FN", v["frame_seg_L"]), _l("frame.D", "F", "FD", v["frame_seg_L"])]
    els += _ladder("shaft.mid", rotor[0], rotor[1], v["shaft_R"], v["shaft_L_mid"], 0.3, 4.0)
    els += _ladder("shaft.N", rotor[0], "SN", v["shaft_R"], v["shaft_L_N"], 0.3, 4.0)
    els += _ladder("shaft.D", rotor[1], "SD", v["shaft_R"], v["shaft_L_D"], 0.3, 4.0)
    els += _bearing("brg.NDE", "SN", "FN", d, speed_rpm, 1.0)
    els += _bearing("brg.DE", "SD", "FD", d, speed_rpm, v["de_size"])
    return Circuit(elements=tuple(els), title=f"independent bench {d.seed} at {speed_rpm:g} rpm")


def with_cable(m: Circuit, d: Draw) -> Circuit:
    """Machine + three-section pi cable per phase + unit inverter sources ``inv.*``."""
    v = d.v
    els: list[Element] = []
    for ph, src in zip(PHASES, INV, strict=True):
        nodes = [f"cab.{ph}.0", f"cab.{ph}.1", f"cab.{ph}.2", ph]
        els.append(Element(src, "vsource", (nodes[0], "0"), 1.0))
        els.append(_c(f"cab.{ph}.C0", nodes[0], "0", v["cab_C"] / 2))
        for k in range(3):
            a, b = nodes[k], nodes[k + 1]
            els += [_r(f"cab.{ph}.R{k}", a, f"cab.{ph}.{k}r", v["cab_R"]),
                    _l(f"cab.{ph}.L{k}", f"cab.{ph}.{k}r", f"cab.{ph}.{k}d", v["cab_L"]),
                    _l(f"cab.{ph}.Ld{k}", f"cab.{ph}.{k}d", b, v["cab_Ld"] / 3),
                    _r(f"cab.{ph}.Rd{k}", f"cab.{ph}.{k}d", b, v["cab_Rd"]),
                    _c(f"cab.{ph}.C{k + 1}", b, "0", v["cab_C"] if k < 2 else v["cab_C"] / 2)]
    return m.extend(els)


# ------------------------------------------------------------------------- inverter
def _edges(d: Draw, speed: float, n_periods: int,
           rng: np.random.Generator) -> list[tuple[ArrF, ArrF]]:
    """Edge start times per phase: regular-sampled PWM with duty jitter per period."""
    v = d.v
    tc = 1 / 8e3
    m = v["m0"] + v["m_per_rpm"] * speed
    f_el = 8 * speed / 60
    tk = np.arange(n_periods) * tc
    out = []
    for i in range(3):
        th = v["theta0"] + 2 * np.pi * f_el * (tk + tc / 2) - 2 * np.pi * i / 3
        duty = (1 + m * np.cos(th)) / 2 + v["jitter"] * rng.standard_normal(n_periods)
        duty = np.clip(duty, 0.03, 0.97)
        out.append((tk + tc / 2 * (1 - duty) - v["t_rise"] / 2,
                    tk + tc / 2 * (1 + duty) - v["t_fall"] / 2))
    return out


def _leg_spectrum(rise: ArrF, fall: ArrF, d: Draw, t_per: float, n: int) -> ArrC:
    """rfft-scaled spectrum of a periodic leg voltage with raised-cosine edges."""
    v = d.v
    k = np.arange(n // 2 + 1)
    w = 2 * np.pi * k / t_per

    def pulse(dur: float) -> ArrC:
        # Fourier transform of the raised-cosine derivative pulse of unit area
        x = w * dur / (2 * np.pi)
        with np.errstate(divide="ignore", invalid="ignore"):
            g = np.sinc(x) / (1 - x**2)
        g[np.isclose(x, 1.0)] = 0.5
        return g

    dv = v["v_dc"]
    pr, pf = pulse(v["t_rise"]), pulse(v["t_fall"])
    der = (dv / t_per) * (pr * np.exp(-1j * np.outer(w, rise + v["t_rise"] / 2)).sum(axis=1)
                          - pf * np.exp(-1j * np.outer(w, fall + v["t_fall"] / 2)).sum(axis=1))
    c = np.zeros(k.size, complex)
    c[1:] = der[1:] / (1j * w[1:])
    c[0] = -dv / 2 + dv * float(np.sum(fall - rise)) / t_per
    return c * n


def _probe(f: ArrF, bw: float, order: int, skew: float = 0.0) -> ArrC:
    s = 1j * f / bw
    h = 1 / (1 + np.sqrt(2) * s + s * s) if order == 2 else 1 / (1 + s)
    return np.asarray(h * np.exp(-2j * np.pi * f * skew), dtype=complex)


def extra_response(net: Circuit, d: Draw, freq_hz: ArrF, h_terminals: ArrC) -> ArrC:
    """``(n_f, 2, 3)`` from the unit inverter sources to ``u_B_DE = v(SD)`` and ``i_CM``.

    ``net`` is :func:`with_cable` of the machine, ``h_terminals`` ``(n_f, 3, 3)`` its
    response at the terminals U, V, W. The current entering the machine at terminal ``p``
    is the current of the cable's last series inductor less the current of the cable's
    end capacitance ``cab_C / 2`` at ``p`` (KCL at the terminal node); ``i_CM`` is the sum
    over the three phases.
    """
    h = net.mna.response(freq_hz, INV, EXTRA_OUTPUTS, method="modal")
    jw_c = 2j * np.pi * freq_hz[:, None] * (d.v["cab_C"] / 2)
    i_cm = h[:, 1:4, :].sum(axis=1) - jw_c * h_terminals.sum(axis=1)
    return np.stack([h[:, 0, :], i_cm], axis=1)


def record(d: Draw, speed: float, rng: np.random.Generator, n_periods: int = 8,
           n_pre: int = 4, extra: dict[str, float] | None = None,
           start: float = 0.0) -> tuple[ArrF, ArrF]:
    """Noise-free probe outputs (4, n) of the last ``n_periods`` PWM periods of a run of
    ``n_pre + n_periods`` jittered periods, and the first rising edges of phase U.
    ``start`` (0..1): the record ends that fraction of a PWM period before the run's end,
    so that it starts anywhere in a period (a scope triggered at random), not at the
    carrier's start.

    With ``extra`` (:func:`draw_extra`) two more rows: ``u_B_DE`` and ``i_CM``
    (:func:`extra_response`), each through its probe."""
    fs = d.fs_hz
    n_all = round((n_pre + n_periods) * fs / 8e3)
    t_all = n_all / fs
    edges = _edges(d, speed, n_pre + n_periods, rng)
    x = np.stack([_leg_spectrum(r, f, d, t_all, n_all) for r, f in edges])
    f = np.arange(x.shape[1]) * fs / n_all
    net = with_cable(machine(d, speed), d)
    # above 30 MHz the edges and the probes leave nothing above the noise: not computed
    band = f <= 30e6
    h = net.mna.response(f[band], INV, ("U", "V", "W", "SN"), method="modal")
    y = np.zeros((4, f.size), complex)
    y[:, band] = np.einsum("foi,if->of", h, x[:, band])
    v = d.v
    for k, ph in enumerate(PHASES):
        y[k] *= _probe(f, v[f"probe_bw_{ph}"], 2)
    y[3] *= _probe(f, v["probe_bw_B"], 1, v["skew_B"])
    if extra is not None:
        he = extra_response(net, d, f[band], h[:, :3, :])
        ye = np.zeros((2, f.size), complex)
        ye[:, band] = np.einsum("foi,if->of", he, x[:, band])
        ye[0] *= _probe(f, extra["probe_bw_B_DE"], 1, extra["skew_B_DE"])
        ye[1] *= _probe(f, extra["probe_bw_I"], 1)
        y = np.concatenate([y, ye])
    k_end = n_all - round(start * fs / 8e3)
    clean = np.fft.irfft(y, n=n_all, axis=1)[:, k_end - round(n_periods * fs / 8e3):k_end]
    return clean, edges[0][0]


def _emi(d: Draw, n: int, rng: np.random.Generator) -> ArrF:
    t = np.arange(n) / d.fs_hz
    w = np.zeros(n)
    for _ in range(5):
        w += rng.uniform(0.3, 1.0) * np.sin(2 * np.pi * rng.uniform(14e6, 37e6) * t
                                            + rng.uniform(0, 2 * np.pi))
    # bursts every ~62.5 us (switching) at a drawn frequency
    fb = rng.uniform(14e6, 37e6)
    for t0 in np.arange(rng.uniform(0, 62.5e-6), n / d.fs_hz, 62.5e-6):
        k0 = int(t0 * d.fs_hz)
        k1 = min(n, k0 + int(1.5e-6 * d.fs_hz))
        tt = t[k0:k1] - t0
        w[k0:k1] += 3 * np.exp(-tt / 200e-9) * np.sin(2 * np.pi * fb * tt)
    return w / np.sqrt(np.mean(w**2))


def bearing_capacitance(d: Draw, speed: float, size: float, freq_hz: float = 100e3) -> float:
    """``Im(Y) / (2 pi f)`` of one bearing of the bench between shaft and frame."""
    z = Circuit(elements=tuple(_bearing("b", "S", "0", d, speed, size))).port_impedance(
        [freq_hz], [("S", "0")])[0, 0, 0]
    return float((1.0 / z).imag / (2 * np.pi * freq_hz))


def cm_transfer(d: Draw, speed: float, freq_hz: float = 100e3) -> float:
    """``|u_SN / u_CM|`` at ``freq_hz``: the NDE shaft-end voltage (the recorded bearing
    voltage) per volt of common-mode voltage at the machine terminals (U, V, W driven
    alike, the cable not in the path: the records' inputs are the terminal voltages)."""
    src = tuple(f"cm.{ph}" for ph in PHASES)
    net = machine(d, speed).extend(
        [Element(n, "vsource", (ph, "0"), 1.0) for n, ph in zip(src, PHASES, strict=True)])
    h = net.mna.response([freq_hz], src, ("SN",))
    return float(abs(np.sum(h[0, 0, :])))


def equivalents(d: Draw, speed: float) -> dict[str, float]:
    """Truth quantities comparable with the grey-box model's parameters.

    ``c_wr_f`` (all phases) and ``c_rf_f`` at high frequency (above the Debye relaxations:
    the bare capacitances) and at 1 kHz (with both loss branches); ``film_c_f``: the
    high-frequency capacitance of one bearing's films (inner and outer contact in series,
    each contact oil and thickener in series), averaged over the two bearings (the model's
    bearings are identical); ``c_b_100khz_f``: the effective capacitance of a bearing at
    100 kHz (network admittance, mean of the two bearings); ``film_r_ohm``: twice the DC
    resistance of the two bearings' films in parallel (the model's per-bearing equivalent);
    ``cm_transfer_100khz``: :func:`cm_transfer` at 100 kHz.
    """
    v = d.v
    kd = 1 + v["k1"] + v["k2"]
    out = {"c_wr_f": 3 * v["C_wr"], "c_rf_f": v["C_rf"],
           "c_wr_lf_f": 3 * v["C_wr"] * kd, "c_rf_lf_f": v["C_rf"] * kd}
    if speed > 0:
        cs, gs, cbs = [], [], []
        for size in (1.0, v["de_size"]):
            ci = film_values(d, speed, size, v["area_in"])
            co = film_values(d, speed, size, v["area_out"])
            inv_c = sum(1 / x["C_oil"] + 1 / x["C_th"] for x in (ci, co))
            cs.append(1 / inv_c)
            gs.append(1 / sum(x["R_oil"] + x["R_th"] for x in (ci, co)))
            # divider capacitance of the bearing: each contact's film with its edge
            # capacitance, inner and outer contact in series, and the air capacitance
            ce = [1 / (1 / x["C_oil"] + 1 / x["C_th"]) + v["C_edge"] * size * a
                  for x, a in ((ci, v["area_in"]), (co, v["area_out"]))]
            cbs.append(1 / (1 / ce[0] + 1 / ce[1]) + v["C_air"] * size)
        out["film_c_f"] = float(np.mean(cs))
        out["c_b_100khz_f"] = float(np.mean([bearing_capacitance(d, speed, size)
                                             for size in (1.0, v["de_size"])]))
        out["film_r_ohm"] = float(2 / sum(gs))
        out["c_b_f"] = float(np.mean(cbs))
        out["cm_transfer_100khz"] = cm_transfer(d, speed)
    return out


def _noisy_spectrum(z: ArrC, rel: float, rng: np.random.Generator) -> ArrC:
    return z + rel * np.abs(z) * (rng.standard_normal(z.size)
                                  + 1j * rng.standard_normal(z.size)) / np.sqrt(2)


def shaft_frame_impedance(d: Draw, speed: float, freq_hz: ArrF) -> ArrC:
    """Noise-free ``Shaft-Frame`` impedance of the machine at ``speed`` (terminals open)."""
    return machine(d, speed).mna.response(freq_hz, [SHAFT_FRAME], [SHAFT_FRAME])[:, 0, 0]


def write_bench(out: Path, seed: int, speeds: tuple[float, ...] = SPEEDS,
                n_periods: int = 8, extra: bool = False,
                random_start: bool = False) -> dict[str, object]:
    """Write bench ``seed`` as a dataset directory ``out`` (atomically); with ``extra`` the
    further measurements of CONTRACT section 2a as well (see the module docstring); with
    ``random_start`` every record starts at a random point of a PWM period
    (:func:`record`'s ``start``, drawn from a generator of its own: the other draws stay)."""
    d = draw(seed)
    ss = np.random.SeedSequence([seed, 77])
    r_imp, r_pwm, r_noise = (np.random.default_rng(s) for s in ss.spawn(3))
    ex = draw_extra(seed) if extra else None
    r_extra = np.random.default_rng(np.random.SeedSequence([seed, 78]))
    with atomic_directory(out) as tmp:
        (tmp / "impedance").mkdir()
        (tmp / "recordings").mkdir()
        f = np.logspace(np.log10(d.f_min_hz), 7, d.n_freq)
        m0 = machine(d, 0.0)
        pairs = [TOPOLOGY_PORTS[t] for t in TOPOLOGY_PORTS]
        zz = m0.mna.response(f, pairs, pairs)
        for i, topo in enumerate(TOPOLOGY_PORTS):
            z = zz[:, i, i]
            z = z + d.v["z_noise"] * np.abs(z) * (r_imp.standard_normal(f.size) + 1j
                                                  * r_imp.standard_normal(f.size)) / np.sqrt(2)
            (tmp / "impedance" / f"{topo}.csv").write_text(csv_text(FrequencyData(f, z, kind="Z")))
        at_speed: list[str] = []
        if extra:
            for s in (0.0, *(x for x in speeds if x > 0)):
                z = _noisy_spectrum(shaft_frame_impedance(d, s, f), d.v["z_noise"], r_extra)
                name = "Shaft-Frame.csv" if s == 0 else f"Shaft-Frame_{round(s):04d}rpm.csv"
                (tmp / "impedance" / name).write_text(csv_text(FrequencyData(f, z, kind="Z")))
                if s > 0:
                    at_speed += ["", "[[impedance_at_speed]]", 'topology = "Shaft-Frame"',
                                 f"speed_rpm = {float(s)}", f'file = "impedance/{name}"']
        r_start = np.random.default_rng(np.random.SeedSequence([seed, 79]))
        starts = {s: float(r_start.uniform()) if random_start else 0.0 for s in speeds}
        clean = {s: record(d, s, r_pwm, n_periods, extra=ex, start=starts[s])[0]
                 for s in speeds}
        b_rms = float(np.std(clean[min(speeds)][3])) / 10 ** (d.v["snr_b0_db"] / 20)
        toml = [f'name = "independent-bench-{seed}"',
                'description = "independent virtual bench (benches/independent.py)"',
                "temperature_c = 80.0", "", "[impedance]"]
        toml += [f'"{t}" = "impedance/{t}.csv"' for t in TOPOLOGY_PORTS]
        if extra:
            toml.append('"Shaft-Frame" = "impedance/Shaft-Frame.csv"')
            i_rms = float(np.std(clean[min(speeds)][5])) / 10 ** (ex["snr_i_cm_db"] / 20)  # type: ignore[index]
        recs: dict[str, object] = {}
        for s in speeds:
            y = clean[s][:4]
            n = y.shape[1]
            emi = _emi(d, n, r_noise)
            rms = np.r_[np.std(y[:3], axis=1) / 10 ** (d.v["snr_terminal_db"] / 20), b_rms]
            noisy = (y + rms[:, None] * (0.8 * r_noise.standard_normal(y.shape)
                                         + 0.6 * emi[None, :]
                                         * r_noise.choice([-1.0, 1.0], size=(4, 1))))
            name = f"rpm{round(s):04d}.npz"
            arrays = {"u_U": noisy[0].astype(np.float32), "u_V": noisy[1].astype(np.float32),
                      "u_W": noisy[2].astype(np.float32), "u_B": noisy[3].astype(np.float32)}
            if extra:
                ye = clean[s][4:]
                rms_e = np.array([b_rms, i_rms])
                noisy_e = ye + rms_e[:, None] * (0.8 * r_extra.standard_normal(ye.shape)
                                                 + 0.6 * emi[None, :]
                                                 * r_extra.choice([-1.0, 1.0], size=(2, 1)))
                arrays.update(u_B_DE=noisy_e[0].astype(np.float32),
                              i_CM=noisy_e[1].astype(np.float32))
            np.savez_compressed(tmp / "recordings" / name, **arrays,
                                fs=np.float64(d.fs_hz))
            toml += ["", "[[recording]]", f"speed_rpm = {float(s)}", f'file = "recordings/{name}"']
            recs[str(round(s))] = {
                "peak_u_b_clean_v": float(np.abs(brickwall_filter(y[3], d.fs_hz, 10e6)).max()),
                # what a perfect model can reach against this noisy record
                "spectral_corr_ceiling": spectral_corr(y[3], noisy[3].astype(np.float32),
                                                       d.fs_hz),
                "spectral_corr_periodogram_ceiling": spectral_corr_periodogram(
                    y[3], noisy[3].astype(np.float32), d.fs_hz),
                "equivalents": equivalents(d, s), "record_start_periods": starts[s]}
            if extra:
                recs[str(round(s))].update({  # type: ignore[attr-defined]
                    "peak_u_b_de_clean_v": float(np.abs(brickwall_filter(
                        clean[s][4], d.fs_hz, 10e6)).max()),
                    "rms_i_cm_clean_a": float(np.std(clean[s][5]))})
        toml += at_speed
        (tmp / "dataset.toml").write_text("\n".join(toml) + "\n")
        summary: dict[str, object] = {
            "seed": seed, "generator": "benches/independent.py", "values": d.v,
            "n_coils": d.n_coils, "fs_hz": d.fs_hz, "n_freq": d.n_freq,
            "bearing_noise_rms_v": b_rms, "recordings": recs,
            "equivalents": equivalents(d, 100.0)}
        if extra:
            summary.update(extra_measurements=ex, i_cm_noise_rms_a=i_rms)
        (tmp / "truth.json").write_text(json.dumps(summary, indent=1) + "\n")
    return summary
