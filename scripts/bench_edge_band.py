#!/usr/bin/env python
"""Which Shaft-Frame band tells a Hertzian edge capacitance from the film (issue 14).

    .venv/bin/python scripts/bench_edge_band.py [--case pmsm_edge] [--seed 0] [--rpm 100]

For a concealed bearing case (:data:`benches.concealed.BEARING_CASES`), the noise-free
Shaft-Frame impedance of the truth at standstill and at ``--rpm`` is fitted by the network
without the edge capacitance (the case's starting effects, 3-rung ladders as the
detective's network), every value of the shaft-to-frame path free: the machine values
shared by both spectra, the film, thickener layer and contact resistance per state
(``scipy.optimize.least_squares``, ``ln p``). Printed per band up to 10 MHz (the spectra's
band) and up to 100 MHz (:data:`vfmodel.detective.recommend.WIDE_F_HI_HZ`): the chi-square
of the misfit at the noise of the bench (0.5 % of ``|Z|``, ``Re`` and ``Im`` of ``ln Z``),
per decade band. The edge case against its null (``--case pmsm_null_bearing``: the same
ladders' discretisation misfit only) says how much of the wide band's misfit is the edge.
Seed 0, 100 rpm (2026-11-28): edge 1.7 (10 MHz) / 172 (100 MHz, 91 of it at 10-30 MHz at
100 rpm); null 8.4 / 41.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the benches package

from benches.concealed import BEARING_CASES, BenchConfig, truth_values
from benches.drive_extra import shaft_frame_impedance
from benches.truth import lubricant_at_speed
from vfmodel.greybox.network import NetSpec

_LUB = ("lubricant.R_1", "lubricant.C_1", "lubricant.R_2", "lubricant.C_2", "bearing.R_h")
_PATH = ("ball.R_dc", "ball.L_ext", "ball.L_int", "ball.rho", "shaft.L_1", "shaft.L_int",
         "shaft.rho", "shaft.R_dc", "bearing.C_air", "airgap.C_rf", "insulation.C_wr",
         "frame.L_ext", "frame.L_int", "frame.R_dc", "frame.rho")
_BANDS = ((1e3, 1e6), (1e6, 1e7), (1e7, 3e7), (3e7, 1.01e8))


def misfit(case_name: str, seed: int, rpm: float, f_hi: float, points: int = 301
           ) -> dict[str, float]:
    """Chi-square of the edge-free network's best fit per band (and ``total``)."""
    case = {c.name: c for c in BEARING_CASES}[case_name]
    cfg = case.config(BenchConfig())
    p, _ = truth_values(case, seed, False, cfg)
    f = np.geomspace(1e3, f_hi, points)
    data = []
    for s in (0.0, rpm):
        ps, st = lubricant_at_speed(p, s)
        data.append((ps, st, shaft_frame_impedance(cfg.spec(case.truth_effects).build(ps, st),
                                                   f)))
    model = NetSpec(case.start_effects - {"hertzian_edge_capacitance"}, 3, cfg.n_sections)
    edge = "hertzian_edge_capacitance" in case.truth_effects
    ps1 = data[1][0]
    x0 = np.log([ps1[n] for n in _PATH] + [ps1[n] for n in _LUB])
    x0[len(_PATH) + 1] = np.log(ps1["lubricant.C_1"] + (ps1["bearing.C_edge"] if edge else 0))
    sigma = 0.005 / np.sqrt(2)

    def res(x: np.ndarray) -> np.ndarray:
        mach = dict(zip(_PATH, np.exp(x[:len(_PATH)]), strict=True))
        lub = dict(zip(_LUB, np.exp(x[len(_PATH):]), strict=True))
        out = []
        for k, (ps, st, zt) in enumerate(data):
            q = ps.with_values({**mach, **(lub if k else {})}, clip=True)
            r = np.log(shaft_frame_impedance(model.build(q, st), f) / zt) / sigma
            out.append(np.r_[r.real, r.imag])
        return np.concatenate(out)

    r = least_squares(res, x0, method="trf", max_nfev=400).fun
    n = f.size
    chi = np.zeros(n)
    for k in range(2):
        blk = r[2 * n * k: 2 * n * (k + 1)]
        chi += blk[:n] ** 2 + blk[n:] ** 2
    out = {"total": float(np.sum(r**2))}
    for lo, hi in _BANDS:
        m = (f >= lo) & (f < hi)
        if m.any():
            out[f"{lo:.0e}-{min(hi, f_hi):.0e}"] = float(np.sum(chi[m]))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", default="pmsm_edge")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--rpm", type=float, default=100.0)
    a = ap.parse_args()
    for f_hi in (1e7, 1e8):
        got = misfit(a.case, a.seed, a.rpm, f_hi)
        bands = ", ".join(f"{k} Hz {v:.1f}" for k, v in got.items() if k != "total")
        print(f"{a.case} seed {a.seed}, standstill + {a.rpm:g} rpm, to {f_hi:.0e} Hz: "
              f"chi2 {got['total']:.1f} ({bands})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
