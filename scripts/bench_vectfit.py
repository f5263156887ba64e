"""Benchmark: scikit-rf VectorFitting.auto_fit and vfmodel.vector_fit(order="auto") on the
same data in one process. Prints, per case, both times (median of --runs), their ratio,
both orders (every pole counted, each complex pole of a conjugate pair separately) and both
relative RMS errors ||H_model - H_data||_F / ||H_data||_F (CONTRACT section 4), computed
the same way for both tools on the same data and representation.

    .venv/bin/python scripts/bench_vectfit.py [--runs 5] [--threads 1] [--cases agilent,...]

``--threads N`` sets OPENBLAS/OMP thread counts before numpy loads (both tools share it);
on a loaded 2-core machine multithreaded BLAS slows both tools by an order of magnitude.
The runs of the two tools alternate, so that a changing machine load affects both alike.
scikit-rf's auto_fit on the CST file (601 points from 0 Hz) takes many minutes per run:
use ``--cases cst --runs 1`` for it.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
import warnings
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
TOUCHSTONE = ROOT.parent / "shared" / "data" / "touchstone"


def _args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--threads", type=int, default=1, help="BLAS threads (0: leave as is)")
    p.add_argument("--cases", default="agilent,cst,motor,synthetic")
    return p.parse_args()


def main() -> int:
    args = _args()
    if args.threads > 0:
        for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ[var] = str(args.threads)
    import numpy as np
    import skrf

    sys.path.insert(0, str(ROOT))
    from benches.skrf_reference import skrf_order, skrf_response
    from tests._motor_like import motor_like_impedance
    from tests._vf_models import known_model
    from vfmodel import FrequencyData, vector_fit

    warnings.simplefilter("ignore")

    def rel(model_h: Any, data_h: Any) -> float:
        return float(np.linalg.norm(model_h - data_h) / np.linalg.norm(data_h))

    cases: dict[str, tuple[Any, str, dict[str, Any]]] = {}
    names = args.cases.split(",")
    if "agilent" in names:
        cases["agilent"] = (skrf.Network(str(TOUCHSTONE / "Agilent_E5071B.s4p")), "s", {})
    if "cst" in names:
        cases["cst"] = (skrf.Network(str(TOUCHSTONE / "cst_example_4ports.s4p")), "s", {})
    if "motor" in names:
        f = np.geomspace(1e3, 1e7, 500)
        fd = FrequencyData(f, motor_like_impedance(f), kind="Z")
        cases["motor (Z, inv_abs)"] = (fd, "z", {"weighting": "inv_abs", "fit_e": True})
    if "synthetic" in names:
        truth = known_model(4, 2, 6, seed=3, with_e=False)
        f = np.geomspace(1e3, 1e7, 300)
        fd = FrequencyData(f, truth(f), kind="Z").to_kind("S", 50.0)
        cases["synthetic 4-port S (true order 14 per Z, <=56 in S)"] = (fd, "s", {})

    print(
        f"BLAS threads: {os.environ.get('OPENBLAS_NUM_THREADS', 'default')}, runs: {args.runs}",
        flush=True,
    )
    header = (
        f"{'case':<52} {'skrf s':>8} {'vfm s':>8} {'ratio':>7} {'skrf N':>7} {'vfm N':>6} "
        f"{'skrf relRMS':>12} {'vfm relRMS':>11}"
    )
    print(header)
    for name, (obj, ptype, kw) in cases.items():
        if isinstance(obj, FrequencyData):
            fd, net = obj, obj.to_network(z0=50.0)
        else:
            net = obj
            fd = FrequencyData.from_network(net, kind="S")
        data_h = fd.values if ptype == "s" or fd.kind == "Z" else None
        t_skrf, t_vf = [], []
        vf_skrf: Any = None
        model: Any = None
        report: Any = None
        for _ in range(args.runs):
            t0 = time.perf_counter()
            vf_skrf = skrf.vectorFitting.VectorFitting(net)
            vf_skrf.auto_fit(parameter_type=ptype)
            t_skrf.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            model, report = vector_fit(fd, "auto", **kw)
            t_vf.append(time.perf_counter() - t0)
        h_skrf = skrf_response(vf_skrf, fd.freq_hz)
        ts, tv = statistics.median(t_skrf), statistics.median(t_vf)
        print(
            f"{name:<52} {ts:8.3f} {tv:8.3f} {ts / tv:7.1f} {skrf_order(vf_skrf):7d} "
            f"{report.order:6d} {rel(h_skrf, data_h):12.3e} {rel(model(fd.freq_hz), data_h):11.3e}",
            flush=True,
        )
        print(f"    vfmodel: {report.order_reason}", flush=True)
        if name == "agilent":
            # equal-order comparison: vfmodel with scikit-rf's order given
            _m_eq, r_eq = vector_fit(fd, skrf_order(vf_skrf), spacing="lin")
            print(
                f"    vfmodel at scikit-rf's order {r_eq.order}: rel RMS {r_eq.rel_rms_error:.3e} "
                f"({r_eq.n_iterations} iterations)",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
