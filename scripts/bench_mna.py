"""Benchmark: vfmodel MNA frequency sweep vs ngspice ``.ac`` on the same netlist.

One random RLC network (with switches and mutual inductances) is exported to ngspice;
both tools compute all node voltages on ngspice's own log-spaced frequency grid. Reported:
wall time of one ngspice run (process start, parse, sweep, write), of the vfmodel sweep
for each solver, their ratio, the largest relative difference, and the time of one
response + adjoint Jacobian evaluation (the inner loop of identification).

Usage::

    .venv/bin/python scripts/bench_mna.py [--elements 300] [--nodes 120] [--ppd 200]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

# one BLAS thread: on a shared 2-core machine threaded BLAS is oversubscribed and batched
# small solves get ~40x slower (measured); set before numpy is imported
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the benches package

from benches.random_networks import random_rlc_network
from vfmodel.circuit.ngspice import run_ac
from vfmodel.circuit.spice_export import spice_names, to_spice


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--elements", type=int, default=300)
    ap.add_argument("--nodes", type=int, default=120)
    ap.add_argument("--ppd", type=int, default=200, help="points per decade, 100 Hz-10 MHz")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    c = random_rlc_network(np.random.default_rng(args.seed), n_nodes=args.nodes,
                           n_elements=args.elements, n_switches=4, n_mutual=10)
    _, nmap = spice_names(c)
    probes = [f"v({nmap[n]})" for n in c.nodes]
    text = to_spice(c)
    t0 = time.perf_counter()
    res = run_ac(text, probes, f_start_hz=100.0, f_stop_hz=1e7, points_per_decade=args.ppd)
    t_ng = time.perf_counter() - t0
    f = res.freq_hz
    mna = c.mna
    print(f"network: {len(c)} elements, {len(c.nodes)} nodes, {mna.size} MNA unknowns, "
          f"{f.size} frequencies, {len(probes)} outputs")
    print(f"ngspice .ac (one run, incl. process start): {t_ng:8.3f} s")
    outs = list(c.nodes)
    b, cout = mna.ac_input[:, None], mna.output_matrix(outs)
    for method in ("dense", "sparse", "hessenberg", "modal"):
        t0 = time.perf_counter()
        sol = mna.solve(f, b, cout, method=method)  # type: ignore[arg-type]
        t_v = time.perf_counter() - t0
        h = sol.h[:, :, 0]
        err = np.max(np.abs(h - res.values) / np.maximum(np.abs(res.values), 1e-300))
        errn = np.max(np.linalg.norm(h - res.values, axis=1)
                      / np.linalg.norm(res.values, axis=1))
        print(f"vfmodel {method:10s} sweep: {t_v:7.3f} s  ngspice/vfmodel = {t_ng / t_v:5.2f}"
              f"  max rel diff pointwise {err:.1e}, norm-wise {errn:.1e}"
              f"  (solver used: {sol.method})")
    for method in ("dense", "hessenberg", "modal"):
        t0 = time.perf_counter()
        sol = mna.solve(f, mna.input_matrix(["V1"]), mna.output_matrix(outs[:3]),
                        adjoint=True, method=method)  # type: ignore[arg-type]
        _, jac = mna.response_and_jacobian(f, ["V1"], outs[:3],
                                           method=method)  # type: ignore[arg-type]
        t_j = time.perf_counter() - t0
        print(f"response + adjoint Jacobian ({method}, 1 input, 3 outputs, "
              f"{jac.shape[-1]} params): {t_j / 2:.3f} s  (solver used: {sol.method})")


if __name__ == "__main__":
    main()
