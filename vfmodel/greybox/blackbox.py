"""Black box versus grey box: vector fits of the same data, errors per band, pole maps.

The black box is a rational model fitted by vector fitting (order selected at the noise
floor) to each measured impedance spectrum and to each measured H1 transfer
(terminals -> bearing voltage). It shows what the data support; the identified grey-box
network shows what the physics explains. Compared per frequency band:

- impedance: MAPE of ``|Z|`` (:func:`vfmodel.greybox.metrics.mape_pct`) of the grey box and
  the black box in each band;
- bearing transfer: relative RMS error ``||H_model - H1_meas|| / ||H1_meas||`` over the bins
  and inputs of each band (grey box: the H1 of its output through the same estimator,
  reference paper eq. 21; black box: the rational model at the bins).

Pole maps: the fitted poles against the network's natural frequencies
(:func:`vfmodel.circuit.poles.network_poles`) of the standstill network (impedance) and of
the rotating network (bearing transfer); a fitted pole without a network pole nearby
marks dynamics the network lacks.
"""

from __future__ import annotations

import itertools
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vfmodel.circuit.poles import network_poles
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.progress import Progress, no_progress
from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import FitError, InputError, VfmodelWarning
from vfmodel.fitting.vectfit import vector_fit
from vfmodel.greybox.identify import Identification
from vfmodel.greybox.metrics import band_mape_pct

__all__ = ["BANDS_HZ", "BlackBoxComparison", "compare_blackbox"]

BANDS_HZ = (1e3, 1e4, 1e5, 1e6, 1e7)
ArrC = NDArray[np.complex128]


@dataclass(frozen=True)
class BlackBoxComparison:
    """Errors per band (``bands_hz`` edges) of grey and black box, and the pole sets.

    ``impedance[topology]`` and ``bearing[rpm]`` hold ``order``, ``grey`` and ``black``
    (lists, one value per band, None for an empty band) and the overall values;
    ``fitted_poles`` / ``network_poles_*`` are in rad/s.
    """

    bands_hz: tuple[float, ...]
    impedance: dict[str, dict[str, object]]
    bearing: dict[str, dict[str, object]]
    models: dict[str, RationalModel]
    network_poles_standstill: ArrC
    network_poles_rotating: ArrC | None

    def to_json_dict(self) -> dict[str, object]:
        return {"bands_hz": list(self.bands_hz), "impedance": self.impedance,
                "bearing": self.bearing,
                "n_network_poles_standstill": int(self.network_poles_standstill.size)}


def _band_rel_rms(f: NDArray[np.float64], h: ArrC, ref: ArrC,
                  edges: tuple[float, ...]) -> list[float | None]:
    out: list[float | None] = []
    for lo, hi in itertools.pairwise(edges):
        sel = (f >= lo) & (f <= hi)
        if not np.any(sel):
            out.append(None)
            continue
        out.append(float(np.linalg.norm(h[sel] - ref[sel]) / np.linalg.norm(ref[sel])))
    return out


def _fit(data: FrequencyData) -> RationalModel | None:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", VfmodelWarning)
            model, _ = vector_fit(data, order="auto")
    except (FitError, InputError):
        return None
    return model


def compare_blackbox(ident: Identification, *, bands_hz: tuple[float, ...] = BANDS_HZ,
                     progress: Progress = no_progress) -> BlackBoxComparison:
    """Vector-fit the identification's spectra and H1 transfers and compare (see module)."""
    imp: dict[str, dict[str, object]] = {}
    bea: dict[str, dict[str, object]] = {}
    models: dict[str, RationalModel] = {}
    total = (len(ident.impedance.topologies) if ident.impedance else 0) + len(ident.speeds)
    done = 0
    progress("black box", 0, max(total, 1))
    if ident.impedance is not None:
        t = ident.impedance
        zg = t.model(ident.params)
        for i, topo in enumerate(t.topologies):
            fd = FrequencyData(t.freq_hz, t.z_meas[:, i, None, None], kind="Z")
            m = _fit(fd)
            entry: dict[str, object] = {
                "grey": band_mape_pct(t.freq_hz, zg[:, i], t.z_meas[:, i], bands_hz)}
            if m is not None:
                models[f"impedance:{topo}"] = m
                entry["order"] = m.n_poles
                entry["black"] = band_mape_pct(t.freq_hz, m(t.freq_hz)[:, 0, 0],
                                               t.z_meas[:, i], bands_hz)
            imp[topo] = entry
            done += 1
            progress("black box", done, total)
    for sf in ident.speeds:
        term = sf.term
        f = term.freq_hz
        hg = term.h1_model(sf.params)
        entry = {"grey": _band_rel_rms(f, hg, term.h_meas, bands_hz)}
        fd = FrequencyData(f, term.h_meas[:, None, :], kind="H")
        m = _fit(fd)
        if m is not None:
            models[f"bearing:{sf.speed_rpm:g}"] = m
            entry["order"] = m.n_poles
            entry["black"] = _band_rel_rms(f, m(f)[:, 0, :], term.h_meas, bands_hz)
        bea[f"{sf.speed_rpm:g}"] = entry
        done += 1
        progress("black box", done, total)
    p_st = network_poles(ident.spec.build(ident.params, "standstill"))
    rot = [s for s in ident.speeds if s.state == "rotating"]
    p_rot = network_poles(ident.spec.build(rot[-1].params, "rotating")) if rot else None
    return BlackBoxComparison(tuple(bands_hz), imp, bea, models, p_st, p_rot)
