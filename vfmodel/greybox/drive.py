"""Drive model: inverter waveforms, cable, probe and the periodic steady-state response.

Pure functions (no file I/O). The drive is a two-level SiC inverter (sine-triangle PWM,
regular sampled, trapezoidal edges with rise time ``t_rise`` and fall time ``t_fall``,
DC-link midpoint at frame potential) feeding the machine network through a lumped cable
(series R-L per phase and shunt capacitance to the grounded shield), which
gives the terminal ringing.

Steady state: a record is an integer number of PWM periods and is computed as the
periodic steady state of the network driven by the periodic extension of the record's
inverter voltages. The inverter voltages' Fourier coefficients are exact (closed form for
trapezoidal edges, no sampling of the edges); each harmonic is multiplied by the network
transfer (MNA at every FFT bin), by the probe response (2nd-order Butterworth low-pass,
bandwidth ``probe_bw_hz``) and transformed back. So the record does not start from rest:
slow film time constants longer than the record are in steady state.

``predict --inverter`` drives an identified network with it; the virtual test benches
(``benches/``) add their acquisition noise and EMI (``benches/noise.py``) on top.

References
----------
Reference paper (grey-box bearing-voltage model of a 40-kW PMSM), Sec. II-C: 8 kHz SiC
inverter, t_r = 51 ns, t_f = 26 ns, probe bandwidth 25 MHz, EMI above 10 MHz, input SNR
35.1 dB, bearing-voltage SNR 1.28 dB at 0 rpm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vfmodel.circuit.mna import MnaSystem
from vfmodel.circuit.netlist import Circuit, Element
from vfmodel.errors import InputError
from vfmodel.signals.periodic import periodic_response

__all__ = [
    "CableSpec",
    "InverterSpec",
    "ScopeSpec",
    "drive_circuit",
    "edge_spectrum",
    "inverter_spectra",
    "probe_response",
    "pwm_edges",
    "steady_state",
]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]
INV_SOURCES = ("inv.U", "inv.V", "inv.W")
OUTPUTS = ("U", "V", "W", "SN")


@dataclass(frozen=True)
class InverterSpec:
    """Two-level inverter with sine-triangle PWM.

    The modulation index is ``m_0 + m_per_rpm * speed`` (V/f-like; ``m_0`` holds the
    standstill current); the electrical frequency is ``pole_pairs * speed / 60``.
    """

    f_sw_hz: float = 8e3
    v_dc: float = 240.0
    t_rise_s: float = 51e-9
    t_fall_s: float = 26e-9
    pole_pairs: int = 8
    m_0: float = 0.08
    m_per_rpm: float = 5e-4
    theta0_rad: float = 0.4
    d_min: float = 0.02


@dataclass(frozen=True)
class CableSpec:
    """Lumped cable per phase: ``inv -R-L-(L_damp || R_damp)- terminal``, shunt ``C`` to
    frame at the terminal. ``R_damp || L_damp`` is the high-frequency (skin-effect and
    shield) loss: negligible at the fundamental, ``R_damp`` above ``R_damp/(2 pi L_damp)``."""

    r_ohm: float = 0.05
    l_h: float = 0.3e-6
    l_damp_h: float = 3.0e-6
    r_damp_ohm: float = 30.0
    c_f: float = 1.0e-9


@dataclass(frozen=True)
class ScopeSpec:
    """Acquisition: sample rate, record length (PWM periods), probe bandwidth, noise."""

    fs_hz: float = 100e6
    n_periods: int = 8
    probe_bw_hz: float = 25e6
    snr_terminal_db: float = 35.0
    snr_bearing_db_standstill: float = 1.3
    emi_fraction: float = 0.3
    emi_band_hz: tuple[float, float] = (12e6, 45e6)


def pwm_edges(inv: InverterSpec, speed_rpm: float, n_periods: int,
              ) -> list[tuple[ArrF, ArrF]]:
    """Rising and falling edge start times (s) per phase over ``n_periods`` PWM periods.

    Regular-sampled symmetric PWM: in carrier period k the phase is high for the fraction
    ``d = (1 + m cos(theta_k - 2 pi i / 3)) / 2`` centred in the period. Returns per phase
    ``(t_rise_start, t_fall_start)``.
    """
    tc = 1.0 / inv.f_sw_hz
    m = inv.m_0 + inv.m_per_rpm * speed_rpm
    f_el = inv.pole_pairs * speed_rpm / 60.0
    tk = np.arange(n_periods) * tc
    out = []
    for i in range(3):
        theta = inv.theta0_rad + 2 * np.pi * f_el * (tk + tc / 2) - 2 * np.pi * i / 3
        d = np.clip((1 + m * np.cos(theta)) / 2, inv.d_min, 1 - inv.d_min)
        # edge centres at tk + tc/2 -/+ d tc/2; starts shifted by half the edge duration
        rise = tk + tc / 2 * (1 - d) - inv.t_rise_s / 2
        fall = tk + tc / 2 * (1 + d) - inv.t_fall_s / 2
        out.append((rise, fall))
    return out


def edge_spectrum(t_rise: ArrF, t_fall: ArrF, v_low: float, v_high: float, dur_rise: float,
                  dur_fall: float, t_period: float, n_samples: int, fs: float) -> ArrC:
    """``rfft``-scaled spectrum (``n_samples // 2 + 1`` bins) of a periodic two-level wave.

    The wave rises linearly from ``v_low`` to ``v_high`` in ``dur_rise`` from each
    ``t_rise`` and falls in ``dur_fall`` from each ``t_fall`` (period ``t_period =
    n_samples / fs``). Fourier coefficients of the derivative (rectangular pulses) are
    ``(dV/T) exp(-j w t_mid) sinc(w dur / 2)``; the wave's are those over ``j w``, the mean
    is the high level's duty. Scaled by ``n_samples`` so that ``irfft`` gives samples of the
    band-limited wave (harmonics above ``fs/2`` dropped).
    """
    if not np.isclose(t_period * fs, n_samples):
        raise InputError("record length must be the period", found=f"{t_period * fs} samples",
                         expected=str(n_samples))
    n = np.arange(n_samples // 2 + 1)
    w = 2 * np.pi * n / t_period
    dv = v_high - v_low
    mid_r = t_rise + dur_rise / 2
    mid_f = t_fall + dur_fall / 2
    sr = np.sinc(w * dur_rise / (2 * np.pi))   # np.sinc(x) = sin(pi x)/(pi x)
    sf = np.sinc(w * dur_fall / (2 * np.pi))
    d = (dv / t_period) * (sr * np.exp(-1j * np.outer(w, mid_r)).sum(axis=1)
                           - sf * np.exp(-1j * np.outer(w, mid_f)).sum(axis=1))
    c = np.zeros(n.size, dtype=complex)
    c[1:] = d[1:] / (1j * w[1:])
    c[0] = v_low + dv * float(np.sum(mid_f - mid_r)) / t_period
    return c * n_samples


def inverter_spectra(inv: InverterSpec, speed_rpm: float, scope: ScopeSpec) -> ArrC:
    """Spectra (3, n_bins) of the inverter leg voltages w.r.t. the DC-link midpoint."""
    n = round(scope.n_periods * scope.fs_hz / inv.f_sw_hz)
    t_period = n / scope.fs_hz
    edges = pwm_edges(inv, speed_rpm, scope.n_periods)
    return np.stack([edge_spectrum(r, f, -inv.v_dc / 2, inv.v_dc / 2, inv.t_rise_s,
                                   inv.t_fall_s, t_period, n, scope.fs_hz)
                     for r, f in edges])


def drive_circuit(machine: Circuit, cable: CableSpec) -> Circuit:
    """Machine network + cable + unit inverter sources ``inv.U/V/W`` (w.r.t. frame)."""
    els: list[Element] = []
    g = machine.ground
    for p, src in zip(("U", "V", "W"), INV_SOURCES, strict=True):
        a = f"cable.{p}.inv"
        m = f"cable.{p}.m"
        d = f"cable.{p}.d"
        els += [Element(src, "vsource", (a, g), 1.0),
                Element(f"cable.{p}.R", "resistor", (a, m), cable.r_ohm),
                Element(f"cable.{p}.L", "inductor", (m, d), cable.l_h),
                Element(f"cable.{p}.L_damp", "inductor", (d, p), cable.l_damp_h),
                Element(f"cable.{p}.R_damp", "resistor", (d, p), cable.r_damp_ohm),
                Element(f"cable.{p}.C_term", "capacitor", (p, g), cable.c_f)]
    return machine.extend(els)


def probe_response(freq_hz: ArrF, bw_hz: float) -> ArrC:
    """2nd-order Butterworth low-pass ``1 / (1 + sqrt2 s/w0 + (s/w0)^2)``, ``w0 = 2 pi bw``."""
    s = 1j * np.asarray(freq_hz, dtype=float) / bw_hz
    return 1.0 / (1.0 + np.sqrt(2.0) * s + s * s)


def steady_state(machine: Circuit, inv: InverterSpec, cable: CableSpec, scope: ScopeSpec,
                 speed_rpm: float, *, mna: MnaSystem | None = None) -> ArrF:
    """Noise-free periodic steady state (4, n_samples): u_U, u_V, u_W, u_B after the probe.

    ``mna`` may be the compiled system of ``drive_circuit(machine, cable)`` to reuse.
    """
    x = inverter_spectra(inv, speed_rpm, scope)
    n = round(scope.n_periods * scope.fs_hz / inv.f_sw_hz)
    f = np.arange(x.shape[1]) * scope.fs_hz / n
    sys = drive_circuit(machine, cable).mna if mna is None else mna
    h = sys.response(f, INV_SOURCES, OUTPUTS, method="modal")     # (n_f, 4, 3)
    h = h * probe_response(f, scope.probe_bw_hz)[:, None, None]
    return periodic_response(h, x, n)
