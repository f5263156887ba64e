#!/usr/bin/env python
"""Write the concealed-effect datasets of the detective (``data/concealed/``).

    .venv/bin/python scripts/make_concealed.py [--out data/concealed] [--only CASE] [--seed 0]
    .venv/bin/python scripts/make_concealed.py --seed 7 --unseen --out /tmp/unseen7
    .venv/bin/python scripts/make_concealed.py --seed 8 --unseen --truth-rungs 5 \
        --truth-sections 3 --out /tmp/unseen8

Each case is a dataset generated with one effect present (small, under realistic noise)
that the model the detective starts from lacks, or with nothing missing (null cases).
``cases.json`` lists per case: the model (``--model`` file or PMSM ``--without`` list),
the concealed effect and its location, the decoys (named but absent from the data) and the
expected result. Deterministic for a given seed. ``--seed N --unseen`` draws other truth
values and effect sizes (the acceptance style "datasets never seen"; needs ``--out``).
``--truth-rungs`` / ``--truth-sections`` make the truth with another discretisation than
the detective's network (skin-effect ladders with more rungs, more winding sections), so
the starting model cannot reproduce the data exactly even where nothing is concealed.

Bearing-side cases (:data:`benches.concealed.BEARING_CASES`, issue 14): two-layer film,
metallic contact, lubricant dielectric loss, edge capacitance and two null cases, with the
further measurements of CONTRACT section 2a (``<name>_x``; those of
:data:`benches.concealed.COMMITTED_BEARING` are committed) or without them (same truth and
noise less the extras); the uncommitted ones only with ``--only``, e.g. ``--only
pmsm_two_layer,pmsm_edge_x --out DIR``.

PMSM cases (:data:`benches.concealed.PMSM_CASES`): each entry also holds ``size``
(the effect's parameter values), ``proxy_chi2_red`` and ``proxy`` (calibration fit of the
starting model to the noise-free truth, :func:`benches.concealed.proxy_fit`; about
20-60 s per case, ``--no-proxy`` skips it).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the benches package

from benches.concealed import (
    BEARING_CASES,
    COMMITTED_BEARING,
    PMSM_CASES,
    BenchConfig,
    ConcealedCase,
    bearing_sigma,
    generate,
    proxy_fit,
    write_case,
)
from vfmodel.core.atomic import atomic_directory
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.io_spectrum import csv_text
from vfmodel.detective.candidates import make_candidate
from vfmodel.detective.problem import Candidate, Channel
from vfmodel.detective.user_model import UserFamily, read_user_model
from vfmodel.greybox.params import ParamSet

ROOT = Path(__file__).resolve().parents[1]
RC_MODEL = ROOT / "data" / "user-models" / "rc_ladder.net"

# user-network cases: (effect, place, effect parameter values relative to the place)
USER_CASES: dict[str, dict[str, object]] = {
    "rc_dielectric_loss": {"effect": "insulation_dielectric_loss", "location": "C2",
                           "values": {"k_d": 0.12, "f_relax_hz": 60e3}},
    "rc_null": {"effect": None, "location": None, "values": {}},
}




def _truth_values(params: ParamSet, rng: np.random.Generator, sigma: float) -> ParamSet:
    return params.perturbed(rng, sigma)


def make_user_case(out: Path, case: dict[str, object], seed: int, *, n_freq: int = 200,
                   z_noise: float = 0.003, perturb: float = 0.2,
                   band_hz: tuple[float, float] = (1e3, 1e7)) -> dict[str, object]:
    """Write one RC-ladder case to ``out`` (atomically); returns its ``cases.json`` entry."""
    model = read_user_model(RC_MODEL)
    rng = np.random.default_rng(seed)
    f = np.logspace(np.log10(band_hz[0]), np.log10(band_hz[1]), n_freq)
    tp = _truth_values(model.params, rng, perturb)
    # a family on dummy channels only to evaluate the truth network
    chans = tuple(Channel(f"impedance:{p[0]}", f, np.ones(n_freq, complex), np.ones(n_freq))
                  for p in model.ports)
    fam = UserFamily(model, chans, band_hz)
    applied: tuple[Candidate, ...] = ()
    eff = case["effect"]
    vals = dict(case["values"])  # type: ignore[call-overload]
    if eff is not None:
        loc = str(case["location"])
        c_val = tp[loc] if loc in tp else 1.0
        cand = make_candidate(str(eff), loc, c_val, band_hz)
        p = f"{loc}.{eff}"
        upd = {}
        if "k_d" in vals:
            upd = {f"{p}.k_d": vals["k_d"], f"{p}.tau_d": 1 / (2 * np.pi * vals["f_relax_hz"])}
        tp = tp.with_specs(cand.params).with_values(upd)
        applied = (cand,)
    z = fam.predict(applied, tp)
    with atomic_directory(out) as tmp:
        (tmp / "impedance").mkdir()
        for (name, *_), zz in zip(model.ports, z, strict=True):
            noise = z_noise * np.abs(zz) * (rng.standard_normal(n_freq)
                                            + 1j * rng.standard_normal(n_freq)) / np.sqrt(2)
            (tmp / "impedance" / f"{name}.csv").write_text(
                csv_text(FrequencyData(f, zz + noise, kind="Z")))
        (tmp / "truth.json").write_text(json.dumps(
            {"truth_params": tp.as_dict(), "effect": eff, "location": case["location"],
             "z_noise": z_noise, "seed": seed}, indent=1) + "\n")
    return {"kind": "user", "model": str(RC_MODEL.relative_to(ROOT)), "without": [],
            "effect": eff, "location": case["location"], "decoys": [],
            "expected": {"mismatch_found": eff is not None,
                         "findings": [] if eff is None else [[eff, case["location"]]]}}


def make_pmsm_case(out: Path, case: ConcealedCase, seed: int, unseen: bool,
                   proxy: bool = True, cfg: BenchConfig | None = None) -> dict[str, object]:
    """Write one PMSM case to ``out`` (atomically); returns its ``cases.json`` entry."""
    cfg = case.config(cfg or BenchConfig())
    # the proxy fits the detective's structure to a truth of the same structure
    proxy = proxy and cfg.n_rungs == BenchConfig.n_rungs and \
        cfg.n_sections == BenchConfig.n_sections
    data = generate(case, seed, unseen, cfg)
    entry = {**case.entry(), "seed": seed, "unseen": unseen, "size": data.size,
             "note": case.note, "truth_rungs": cfg.n_rungs,
             "truth_sections": cfg.n_sections}
    if proxy:
        res = proxy_fit(case, data.params, bearing_sigma(data), cfg)
        entry["proxy_chi2_red"] = round(res.chi2_red, 4)
        entry["proxy"] = {k: (round(v, 4) if isinstance(v, float) else v)
                          for k, v in res.to_json_dict().items()}
        entry["proxy"]["blocks"] = {k: round(v, 4) for k, v in res.blocks.items()}
    write_case(out, data, {"proxy": entry.get("proxy")})
    return entry


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=None, help="output directory (default data/concealed)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--unseen", action="store_true",
                    help="other truth values, effect sizes (x0.7-1.5) and noise for --seed")
    ap.add_argument("--only", default=None, help="comma-separated case names")
    ap.add_argument("--no-proxy", action="store_true",
                    help="skip the calibration proxy fit (about 1 min per case)")
    ap.add_argument("--truth-rungs", type=int, default=BenchConfig.n_rungs,
                    help="rungs of the truth's skin-effect ladders (detective: 3)")
    ap.add_argument("--truth-sections", type=int, default=BenchConfig.n_sections,
                    help="winding sections of the truth (detective: chosen from 2-4)")
    a = ap.parse_args(argv)
    if a.unseen and a.out is None:
        ap.error("--unseen needs --out (data/concealed holds the committed cases)")
    if a.truth_rungs < 1 or a.truth_sections < 1:
        ap.error(f"--truth-rungs/--truth-sections: expected integers >= 1, got "
                 f"{a.truth_rungs}/{a.truth_sections}")
    cfg = BenchConfig(n_rungs=a.truth_rungs, n_sections=a.truth_sections)
    out = Path(a.out or ROOT / "data" / "concealed")
    out.mkdir(parents=True, exist_ok=True)
    only = set(a.only.split(",")) if a.only else None
    cases_path = out / "cases.json"
    cases = json.loads(cases_path.read_text()) if cases_path.exists() else {}
    for k, (name, case) in enumerate(USER_CASES.items()):
        if only and name not in only:
            continue
        cases[name] = make_user_case(out / name, case, a.seed * 1000 + k)
        print(f"wrote {out / name}", file=sys.stderr)
    for pc in PMSM_CASES + BEARING_CASES:
        if (only and pc.name not in only) or (not only and pc in BEARING_CASES
                                               and pc.name not in COMMITTED_BEARING):
            continue
        t0 = time.perf_counter()
        cases[pc.name] = make_pmsm_case(out / pc.name, pc, a.seed, a.unseen,
                                        proxy=not a.no_proxy, cfg=cfg)
        size = sum(p.stat().st_size for p in (out / pc.name).rglob("*") if p.is_file())
        px = cases[pc.name].get("proxy_chi2_red", "-")
        print(f"wrote {out / pc.name} ({size / 1e6:.2f} MB, {time.perf_counter() - t0:.1f} s, "
              f"proxy chi2_red {px})", file=sys.stderr)
        cases_path.write_text(json.dumps(cases, indent=1, sort_keys=True) + "\n")
    cases_path.write_text(json.dumps(cases, indent=1, sort_keys=True) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
