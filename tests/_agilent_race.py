"""scikit-rf ``auto_fit`` against ``vector_fit(order="auto")`` on the Agilent E5071B file.

Run as ``python -m tests._agilent_race`` (by tests/test_vectfit_agilent.py) so that the BLAS
thread count is fixed before numpy loads; prints one JSON line with both orders, both
relative RMS errors ||H_model - H_data||_F / ||H_data||_F (same formula, same data) and
the per-run times of both tools, measured interleaved in this one process.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import json  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import skrf  # noqa: E402
from skrf.vectorFitting import VectorFitting  # noqa: E402

from benches.skrf_reference import skrf_order, skrf_response  # noqa: E402
from vfmodel import FrequencyData, vector_fit  # noqa: E402

FILE = Path(__file__).resolve().parents[1] / "data" / "touchstone" / "Agilent_E5071B.s4p"


def rel_rms(model_h: np.ndarray, data_h: np.ndarray) -> float:
    """||H_model - H_data||_F / ||H_data||_F (CONTRACT section 4)."""
    return float(np.linalg.norm(model_h - data_h) / np.linalg.norm(data_h))


def race(runs: int = 5) -> dict[str, object]:
    net = skrf.Network(str(FILE))
    fd = FrequencyData.from_network(net, kind="S")
    t_skrf: list[float] = []
    t_vf: list[float] = []
    vf = None
    model = report = None
    for _ in range(runs):
        t0 = time.perf_counter()
        vf = VectorFitting(net)
        with warnings.catch_warnings():  # scikit-rf's own convergence messages
            warnings.simplefilter("ignore")
            vf.auto_fit()
        t_skrf.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        model, report = vector_fit(fd, "auto")
        t_vf.append(time.perf_counter() - t0)
    assert vf is not None and model is not None and report is not None
    h_skrf = skrf_response(vf, fd.freq_hz)
    return {
        "skrf_order": skrf_order(vf),
        "vf_order": int(report.order),
        "skrf_rel_rms": rel_rms(h_skrf, fd.values),
        "vf_rel_rms": rel_rms(model(fd.freq_hz), fd.values),
        "vf_report_rel_rms": float(report.rel_rms_error),
        "skrf_times": t_skrf,
        "vf_times": t_vf,
        "blas_threads": os.environ["OPENBLAS_NUM_THREADS"],
        "reason": report.order_reason,
    }


if __name__ == "__main__":
    print(json.dumps(race()))
