"""The ``predict`` job: bearing voltage of an identified network for new excitations.

The model is a netlist written by ``reproduce`` (``network_<rpm>rpm.cir``: nodes ``U``,
``V``, ``W``, frame ``0`` and ``SN``). The excitation is either a recording (its terminal
voltages, filtered to 10 MHz; the response is the periodic steady state of the record, as
in the identification) or an inverter description (two-level PWM inverter and cable of
:mod:`vfmodel.greybox.drive`, periodic steady state of the whole drive with the model
network as the machine).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace

import numpy as np
import scipy.fft as sfft
from numpy.typing import NDArray

from vfmodel.circuit.netlist import Circuit
from vfmodel.circuit.transfer import transfer_on
from vfmodel.core.recording import Recording
from vfmodel.errors import InputError
from vfmodel.greybox.assembly import BEARING_NODE, PHASES, SOURCES, with_terminal_sources
from vfmodel.greybox.drive import CableSpec, InverterSpec, ScopeSpec, steady_state
from vfmodel.greybox.metrics import (
    peak_errors,
    peak_v,
    settled_window,
    spectral_corr,
    spectral_corr_periodogram,
)
from vfmodel.signals.filters import F_CUT_HZ, brickwall_filter
from vfmodel.signals.periodic import periodic_response

__all__ = ["Prediction", "check_inverter_options", "check_model_nodes", "inverter_options",
           "predict_inverter", "predict_recording"]

ArrF = NDArray[np.float64]


@dataclass(frozen=True)
class Prediction:
    """Terminal voltages (3, n), predicted ``u_B`` (n,), optional measured ``u_B``."""

    fs: float
    terminals: ArrF
    u_b: ArrF
    u_b_measured: ArrF | None
    summary: dict[str, object]


def check_model_nodes(circ: Circuit, source: str | None = None) -> None:
    """InputError (naming ``source``) unless the netlist has the grey-box nodes."""
    missing = [n for n in (*PHASES, BEARING_NODE) if n not in circ.nodes]
    if missing:
        raise InputError("model netlist lacks the grey-box nodes", source=source,
                         place=", ".join(missing),
                         expected="nodes U, V, W, SN and ground 0 (a network_<rpm>rpm.cir "
                                  "written by vfmodel reproduce)")


def _summary(fs: float, u_b: ArrF, meas: ArrF | None) -> dict[str, object]:
    # peaks on the settled window (vfmodel.greybox.metrics): the periodic response of a
    # record that is not periodic is wrong at its start
    win = settled_window(u_b.size, fs)
    out: dict[str, object] = {"fs_hz": fs, "n_samples": int(u_b.size),
                              "peak_model_v": peak_v(u_b[win], fs, filtered=True),
                              "rms_model_v": float(np.sqrt(np.mean(u_b**2))),
                              "compared_s": [win.start / fs, win.stop / fs]}
    if meas is not None:
        pm = peak_v(meas[win], fs, filtered=True)
        a, r = peak_errors(float(out["peak_model_v"]), pm)  # type: ignore[arg-type]
        out.update({"peak_measured_v": pm, "abs_err_v": a, "rel_err_pct": r,
                    "spectral_corr": spectral_corr(u_b, meas, fs),
                    "spectral_corr_periodogram": spectral_corr_periodogram(u_b, meas, fs)})
    return out


def predict_recording(model: Circuit, rec: Recording) -> Prediction:
    """Periodic steady-state ``u_B`` for the (10 MHz filtered) terminals of ``rec``."""
    check_model_nodes(model)
    fs = rec.fs
    x = brickwall_filter(rec.terminals, fs, F_CUT_HZ)
    n = x.shape[1]
    freq = sfft.rfftfreq(n, 1.0 / fs)
    sel = freq <= min(F_CUT_HZ, fs / 2)
    mna = with_terminal_sources(model).mna
    b = mna.input_matrix(list(SOURCES))
    cout = mna.output_matrix([BEARING_NODE])
    h = transfer_on(mna, b, cout, mna.values0, freq[sel])
    u_b = periodic_response(h, sfft.rfft(x, axis=1)[:, sel], n)[0]
    meas = brickwall_filter(rec.bearing, fs, F_CUT_HZ) if "u_B" in rec.channels else None
    return Prediction(fs, x, u_b, meas, _summary(fs, u_b, meas))


def inverter_options() -> dict[str, float]:
    """Keys accepted by :func:`predict_inverter` with their defaults."""
    out: dict[str, float] = {"speed_rpm": 100.0}
    for prefix, obj in (("", InverterSpec()), ("cable_", CableSpec()), ("", ScopeSpec())):
        for f in fields(obj):
            v = getattr(obj, f.name)
            if isinstance(v, int | float) and not isinstance(v, bool):
                out[prefix + f.name] = float(v)
    return out


MAX_SAMPLES = 2_000_000
"""Longest inverter record predicted (``n_periods * fs_hz / f_sw_hz`` samples, ~1 GB)."""

# (lower, upper) bounds of the inverter options (cable_*: 0 to 1e9). Integer
# options must be whole numbers. Ranges are wide (any drive a user may describe) but keep
# the record finite and the 10 MHz analysis band below the Nyquist frequency.
_BOUNDS: dict[str, tuple[float, float]] = {
    "speed_rpm": (0.0, 1e6), "f_sw_hz": (1.0, 1e8), "v_dc": (0.0, 1e6),
    "t_rise_s": (1e-12, 1e-3), "t_fall_s": (1e-12, 1e-3), "pole_pairs": (1, 1000),
    "m_0": (0.0, 1.5), "m_per_rpm": (0.0, 1.0), "theta0_rad": (-1e3, 1e3),
    "d_min": (0.0, 0.49), "fs_hz": (2 * F_CUT_HZ, 1e11), "n_periods": (1, 1e6),
    "probe_bw_hz": (1.0, 1e12), "snr_terminal_db": (-200.0, 400.0),
    "snr_bearing_db_standstill": (-200.0, 400.0), "emi_fraction": (0.0, 1e3),
}
_POSITIVE = ("f_sw_hz", "v_dc", "t_rise_s", "t_fall_s", "fs_hz", "probe_bw_hz")
_INTEGER = ("pole_pairs", "n_periods")


def check_inverter_options(
    options: Mapping[str, float],
) -> tuple[InverterSpec, CableSpec, ScopeSpec, float]:
    """Validate inverter options (keys: :func:`inverter_options`) and build the specs.

    InputError naming the key for an unknown key, a non-finite, non-positive (where a
    positive value is needed), fractional (``pole_pairs``, ``n_periods``) or out-of-range
    value, and for a record longer than :data:`MAX_SAMPLES` samples.
    """
    known = inverter_options()
    for k, v in options.items():
        if k not in known:
            raise InputError("unknown inverter option", source="--inverter", place=k,
                             expected="one of " + ", ".join(sorted(known)))
        x = float(v)
        lo, hi = (0.0, 1e9) if k.startswith("cable_") else _BOUNDS.get(k, (-1e30, 1e30))
        if not np.isfinite(x):
            raise InputError("inverter option must be a finite number", source="--inverter",
                             place=k, found=str(v))
        if (k in _POSITIVE or k.startswith("cable_")) and x <= 0:
            raise InputError("inverter option must be positive", source="--inverter", place=k,
                             found=f"{x:g}")
        if k in _INTEGER and x != round(x):
            raise InputError("inverter option must be a whole number", source="--inverter",
                             place=k, found=f"{x:g}")
        if not lo <= x <= hi:
            raise InputError("inverter option out of range", source="--inverter", place=k,
                             found=f"{x:g}", expected=f"{lo:g} to {hi:g}")
    inv, cable, scope = InverterSpec(), CableSpec(), ScopeSpec()
    for k, v in options.items():
        if k.startswith("cable_"):
            cable = replace(cable, **{k[6:]: float(v)})
        elif k in {f.name for f in fields(InverterSpec)}:
            typ = type(getattr(inv, k))
            inv = replace(inv, **{k: typ(round(v) if typ is int else v)})
        elif k in {f.name for f in fields(ScopeSpec)}:
            typ = type(getattr(scope, k))
            scope = replace(scope, **{k: typ(round(v) if typ is int else v)})
    speed = float(options.get("speed_rpm", known["speed_rpm"]))
    n = round(scope.n_periods * scope.fs_hz / inv.f_sw_hz)
    if n > MAX_SAMPLES or n < 64:
        raise InputError("inverter record length out of range", source="--inverter",
                         place="n_periods*fs_hz/f_sw_hz",
                         found=f"{n} samples", expected=f"64 to {MAX_SAMPLES} samples")
    if not inv.t_rise_s + inv.t_fall_s < 1.0 / inv.f_sw_hz:
        raise InputError("switching edges longer than the PWM period", source="--inverter",
                         place="t_rise_s", found=f"{inv.t_rise_s + inv.t_fall_s:g} s",
                         expected=f"t_rise_s + t_fall_s < 1/f_sw_hz = {1 / inv.f_sw_hz:g} s")
    return inv, cable, scope, speed


def predict_inverter(model: Circuit, options: Mapping[str, float]) -> Prediction:
    """Periodic steady state of inverter + cable + model network (keys: inverter_options)."""
    inv, cable, scope, speed = check_inverter_options(options)
    check_model_nodes(model)
    y = steady_state(model, inv, cable, scope, speed)
    fs = scope.fs_hz
    x = brickwall_filter(y[:3], fs, F_CUT_HZ)
    u_b = brickwall_filter(y[3], fs, F_CUT_HZ)
    s = _summary(fs, u_b, None)
    s["speed_rpm"] = speed
    return Prediction(fs, x, u_b, None, s)
