"""Benchmark: `vfmodel fit FILE --passive` at the scale of an 8-port PDN (issue 13: "in
under a minute and 2 GB").

    .venv/bin/python scripts/bench_pdn.py [--ports 8] [--poles 100] [--points 1500]
                                          [--seed 0] [--dir /tmp/bench_pdn] [--keep]

Writes a synthetic passive S-parameter file of PDN-like size and runs the command line
``vfmodel fit FILE --out DIR --passive`` on it in a child process; prints the wall time,
the child's peak resident memory (``getrusage(RUSAGE_CHILDREN).ru_maxrss``), the order,
the fit error, the error after enforcement and the certificate from model.json.

The test file is a random Foster network: ``Y(s) = G + sum_k b_k b_k^T y_k(s)`` with
``y_k`` the admittance ``s / (L_k s^2 + R_k s + 1/C_k)`` of a series RLC branch (one pole
pair each, resonances log-spaced over 1 MHz-5 GHz, quality factors 5-80), ``b_k`` random
port vectors and ``G`` a small PSD conductance: a sum of positive-real scalars times PSD
matrices is positive real, so ``S = (I - z0 Y)(I + z0 Y)^-1`` (z0 = 50 ohm) is bounded
real with McMillan degree ``poles``, like the plane resonances of a power distribution
network seen from its ports. Sampled log-spaced over 100 kHz-10 GHz with 1e-4 relative
complex noise (a simulator's export), written as Touchstone (RI).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
Z0 = 50.0


def pdn_s(ports: int, poles: int, points: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and S-parameters (points, ports, ports) of the test network."""
    rng = np.random.default_rng(seed)
    f = np.geomspace(1e5, 1e10, points)
    s = 2j * np.pi * f
    n_branch = poles // 2
    f_res = np.geomspace(1e6, 5e9, n_branch) * np.exp(0.05 * rng.standard_normal(n_branch))
    q = np.exp(rng.uniform(np.log(5.0), np.log(80.0), n_branch))
    z_char = np.exp(rng.uniform(np.log(0.05), np.log(5.0), n_branch))  # sqrt(L/C), ohm
    w0 = 2 * np.pi * f_res
    ind, cap = z_char / w0, 1.0 / (z_char * w0)
    res = z_char / q
    y = np.zeros((f.size, ports, ports), complex)
    for k in range(n_branch):
        b = rng.standard_normal(ports) * np.exp(-rng.uniform(0, 2, ports))
        yk = s / (ind[k] * s**2 + res[k] * s + 1.0 / cap[k])
        y += yk[:, None, None] * np.outer(b, b)[None] / ports
    g = rng.standard_normal((ports, ports))
    y += (1e-4 * g @ g.T)[None]
    eye = np.eye(ports)[None]
    sp = np.linalg.solve((eye + Z0 * y).transpose(0, 2, 1),
                         (eye - Z0 * y).transpose(0, 2, 1)).transpose(0, 2, 1)
    noise = rng.standard_normal(sp.shape) + 1j * rng.standard_normal(sp.shape)
    sp = sp + 1e-4 * np.abs(sp) * noise / np.sqrt(2)
    return f, sp


def write_touchstone(path: Path, f: np.ndarray, sp: np.ndarray) -> None:
    """Touchstone 1.x, RI format, Hz; one frequency per block, 4 pairs per line."""
    lines = ["! synthetic passive PDN-like network (scripts/bench_pdn.py)",
             f"# HZ S RI R {Z0:g}"]
    for k in range(f.size):
        vals = [f"{v.real:.12e} {v.imag:.12e}" for v in sp[k].ravel()]  # row by row
        rows = [" ".join(vals[i:i + 4]) for i in range(0, len(vals), 4)]
        lines.append(f"{f[k]:.12e} " + rows[0])
        lines += ["  " + r for r in rows[1:]]
    path.write_text("\n".join(lines) + "\n")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--ports", type=int, default=8)
    p.add_argument("--poles", type=int, default=100)
    p.add_argument("--points", type=int, default=1500)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--dir", default="/tmp/bench_pdn")
    p.add_argument("--no-passive", action="store_true", help="fit only")
    a = p.parse_args()
    out = Path(a.dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"pdn_{a.ports}port_{a.poles}poles_{a.points}pts.s{a.ports}p"
    f, sp = pdn_s(a.ports, a.poles, a.points, a.seed)
    write_touchstone(path, f, sp)
    sig = float(np.max(np.linalg.svd(sp, compute_uv=False)))
    print(f"{path}: {a.ports} ports, {a.points} points, {a.poles} poles, "
          f"largest singular value of the data {sig:.6f}", flush=True)
    env = {**os.environ, "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")}
    exe = str(Path(sys.executable).with_name("vfmodel"))
    cmd = [exe, "fit", str(path), "--out", str(out / "fit")]
    if not a.no_passive:
        cmd.append("--passive")
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    rss_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
    print(proc.stdout[-1500:] + proc.stderr[-1500:], end="")
    print(f"exit {proc.returncode}; wall time {wall:.1f} s; peak RSS {rss_mb:.0f} MB")
    mj = out / "fit" / "model.json"
    if proc.returncode == 0 and mj.exists():
        doc = json.loads(mj.read_text())
        pas = doc.get("passivity", {})
        print(f"order {doc['order']}; relative RMS error {doc['rel_rms_error']:.3e} "
              f"(unconstrained {pas.get('unconstrained_rel_rms_error', float('nan')):.3e}); "
              f"passive {doc['passive']}, enforcement programs "
              f"{pas.get('enforcement_iterations')}")
    return proc.returncode


if __name__ == "__main__":
    raise SystemExit(main())
