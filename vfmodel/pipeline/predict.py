"""The ``predict`` job: bearing voltage of an identified network for new excitations.

The model is a netlist written by ``reproduce`` (``network_<rpm>rpm.cir``: nodes ``U``,
``V``, ``W``, frame ``0`` and ``SN``). The excitation is either a recording (its terminal
voltages, filtered to 10 MHz; the response is the periodic steady state of the record, as
in the identification) or an inverter description (two-level PWM inverter and cable of
:mod:`vfmodel.greybox.bench`, periodic steady state of the whole drive with the model
network as the machine).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace

import numpy as np
import scipy.fft as sfft
from numpy.typing import NDArray

from vfmodel.circuit.netlist import Circuit
from vfmodel.core.recording import Recording
from vfmodel.errors import InputError
from vfmodel.greybox._fast import transfer_on
from vfmodel.greybox.assembly import BEARING_NODE, PHASES, SOURCES, with_terminal_sources
from vfmodel.greybox.bench import CableSpec, InverterSpec, ScopeSpec, steady_state
from vfmodel.greybox.metrics import F_CUT_HZ, peak_errors, peak_v, spectral_corr
from vfmodel.signals.filters import brickwall_filter

__all__ = ["Prediction", "inverter_options", "predict_inverter", "predict_recording"]

ArrF = NDArray[np.float64]


@dataclass(frozen=True)
class Prediction:
    """Terminal voltages (3, n), predicted ``u_B`` (n,), optional measured ``u_B``."""

    fs: float
    terminals: ArrF
    u_b: ArrF
    u_b_measured: ArrF | None
    summary: dict[str, object]


def _check_nodes(circ: Circuit) -> None:
    missing = [n for n in (*PHASES, BEARING_NODE) if n not in circ.nodes]
    if missing:
        raise InputError("model netlist lacks the grey-box nodes", place=", ".join(missing),
                         expected="nodes U, V, W, SN and ground 0 (a network_<rpm>rpm.cir "
                                  "written by vfmodel reproduce)")


def _summary(fs: float, u_b: ArrF, meas: ArrF | None) -> dict[str, object]:
    out: dict[str, object] = {"fs_hz": fs, "n_samples": int(u_b.size),
                              "peak_model_v": peak_v(u_b, fs, filtered=True),
                              "rms_model_v": float(np.sqrt(np.mean(u_b**2)))}
    if meas is not None:
        pm = peak_v(meas, fs, filtered=True)
        a, r = peak_errors(float(out["peak_model_v"]), pm)  # type: ignore[arg-type]
        out.update({"peak_measured_v": pm, "abs_err_v": a, "rel_err_pct": r,
                    "spectral_corr": spectral_corr(u_b, meas, fs)})
    return out


def predict_recording(model: Circuit, rec: Recording) -> Prediction:
    """Periodic steady-state ``u_B`` for the (10 MHz filtered) terminals of ``rec``."""
    _check_nodes(model)
    fs = rec.fs
    x = brickwall_filter(rec.terminals, fs, F_CUT_HZ)
    n = x.shape[1]
    freq = sfft.rfftfreq(n, 1.0 / fs)
    sel = freq <= min(F_CUT_HZ, fs / 2)
    mna = with_terminal_sources(model).mna
    b = mna.input_matrix(list(SOURCES))
    cout = mna.output_matrix([BEARING_NODE])
    h = transfer_on(mna, b, cout, mna.values0, freq[sel])
    spec = np.zeros(freq.size, complex)
    spec[sel] = np.einsum("fi,if->f", h[:, 0, :], sfft.rfft(x, axis=1)[:, sel])
    u_b = np.asarray(sfft.irfft(spec, n=n), dtype=float)
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


def predict_inverter(model: Circuit, options: Mapping[str, float]) -> Prediction:
    """Periodic steady state of inverter + cable + model network (keys: inverter_options)."""
    _check_nodes(model)
    known = inverter_options()
    for k in options:
        if k not in known:
            raise InputError("unknown inverter option", place=k,
                             expected="one of " + ", ".join(sorted(known)))
    inv, cable, scope = InverterSpec(), CableSpec(), ScopeSpec()
    for k, v in options.items():
        if k.startswith("cable_"):
            cable = replace(cable, **{k[6:]: float(v)})
        elif k in {f.name for f in fields(InverterSpec)}:
            typ = type(getattr(inv, k))
            inv = replace(inv, **{k: typ(v)})
        elif k in {f.name for f in fields(ScopeSpec)}:
            typ = type(getattr(scope, k))
            scope = replace(scope, **{k: typ(v)})
    speed = float(options.get("speed_rpm", known["speed_rpm"]))
    y = steady_state(model, inv, cable, scope, speed)
    fs = scope.fs_hz
    x = brickwall_filter(y[:3], fs, F_CUT_HZ)
    u_b = brickwall_filter(y[3], fs, F_CUT_HZ)
    s = _summary(fs, u_b, None)
    s["speed_rpm"] = speed
    return Prediction(fs, x, u_b, None, s)
