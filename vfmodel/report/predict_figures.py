"""Figure of ``vfmodel predict``: predicted (and measured) bearing voltage over time."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vfmodel.pipeline.predict import Prediction
from vfmodel.report._mpl import pyplot, save

__all__ = ["plot_prediction"]


def plot_prediction(pred: Prediction, path: Path) -> None:
    """``prediction.png``: the predicted ``u_B`` and, when given, the measured one."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 4))
    t = np.arange(pred.u_b.size) / pred.fs * 1e3
    if pred.u_b_measured is not None:
        ax.plot(t, pred.u_b_measured, lw=0.6, label="measured (10 MHz filter)")
    ax.plot(t, pred.u_b, lw=0.6, label="predicted")
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("u_B (V)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    save(fig, path)
