"""Figures of a vector fit: data vs model magnitude, phase and error per entry."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.rational_model import RationalModel
from vfmodel.report._mpl import pyplot, save

_MAX_ENTRIES = 16
_DENSE = 4000  # model curve points


def plot_fit(data: FrequencyData, model: RationalModel, path: Path, title: str = "") -> None:
    """|H| of data and model and the absolute error, for up to 16 entries. The model is
    drawn on a dense grid (4000 points over the data band), so that resonances between
    the samples show; the error is taken at the data points."""
    plt = pyplot()
    h = model(data.freq_hz)
    pos = data.freq_hz[data.freq_hz > 0]
    f_dense = np.geomspace(pos[0], pos[-1], _DENSE) if pos.size > 1 else pos
    h_dense = model(f_dense)
    entries = [(i, j) for i in range(data.n_out) for j in range(data.n_in)]
    if data.n_out == data.n_in and data.n_out > 1:  # diagonal first, then the rest
        entries.sort(key=lambda ij: (ij[0] != ij[1], ij))
    entries = entries[:_MAX_ENTRIES]
    fig, (ax_m, ax_p) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, (i, j) in enumerate(entries):
        c = colors[k % len(colors)]
        lab = f"{data.kind}{i + 1}{j + 1}"
        ax_m.loglog(data.freq_hz, np.abs(data.values[:, i, j]), ".", ms=2, color=c, label=lab)
        ax_m.loglog(f_dense, np.abs(h_dense[:, i, j]), "-", lw=1, color=c)
        ax_p.semilogx(data.freq_hz, np.degrees(np.angle(data.values[:, i, j])), ".", ms=2,
                      color=c)
        ax_p.semilogx(f_dense, np.degrees(np.angle(h_dense[:, i, j])), "-", lw=1, color=c)
    err = np.abs(h - data.values).reshape(data.n_freq, -1).max(axis=1)
    ax_m.loglog(data.freq_hz, np.maximum(err, 1e-300), "k--", lw=0.8, label="max |error|")
    ax_m.set_ylabel(f"|{data.kind}|")
    ax_p.set_ylabel("phase (deg)")
    ax_p.set_xlabel("frequency (Hz)")
    ax_m.legend(fontsize=7, ncol=4)
    ax_m.set_title(title or f"vector fit, {model.n_poles} poles (dots: data, lines: model)")
    for ax in (ax_m, ax_p):
        ax.grid(True, which="both", alpha=0.3)
    save(fig, path)
