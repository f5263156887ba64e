"""vfbench: vfmodel against scikit-rf on every Touchstone file scikit-rf ships and on the
public files of data/vfbench (sources and licences in data/vfbench/README.md), in one run.

    .venv/bin/python scripts/vfbench.py [--runs 3] [--no-skrf-passive] [--extra DIR ...]
                                        [--files GLOB] [--markdown]

Per file and tool: ports, points, automatic order (every pole counted), relative RMS
error ||H_model - H_data||_F / ||H_data||_F of the S-parameters, median fit time over
``--runs`` (small files: 1-2 ports, <= 2000 points; one run otherwise), the data's own
passivity violation floor (:mod:`vfmodel.fitting.data_passivity`), the error after
passivity enforcement, and whether the enforced model is passive by an *independent*
dense check: the largest singular value on 200,000 log-spaced frequencies from 1e-4 x
the lowest to 1e4 x the highest data frequency, the data frequencies and 0 Hz must not
exceed 1 + 1e-9. "cert" is vfmodel's own certificate (Hamiltonian test with sampling
cross-check), "skrf-pas" scikit-rf's ``is_passive()`` after ``passivity_enforce()``.
Files vfmodel refuses (fewer than 3 points, active data for enforcement) say why.

``--extra DIR`` adds every Touchstone file of DIR (e.g. files that may not be
redistributed). Both tools fit S-parameters with their automatic order; BLAS runs on one
thread (set before numpy loads).
"""

from __future__ import annotations

import argparse
import contextlib
import glob
import os
import signal
import statistics
import sys
import time
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
_SMALL = (2, 2000)  # ports, points of a "small" file (timed over --runs)


def _args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--no-skrf-passive", action="store_true",
                   help="skip scikit-rf's passivity_enforce (slow on large files)")
    p.add_argument("--extra", action="append", default=[], help="more Touchstone folders")
    p.add_argument("--files", default=None, help="only files whose name matches this glob")
    p.add_argument("--markdown", action="store_true", help="print a Markdown table")
    p.add_argument("--skrf-limit", type=float, default=60.0,
                   help="seconds per run after which scikit-rf's fit of a file is stopped "
                   "(NanoVNA-Saver's sucoflex290mm.s1p ran for more than 10 minutes)")
    p.add_argument("--impedance-seeds", default=None,
                   help="instead: per-point error against the noise-free truth of the PMSM "
                   "bench impedances (0.5 %% noise) for these seeds, e.g. 0-5")
    return p.parse_args()


def _impedance_truth(seeds: list[int]) -> None:
    """Per-point relative error of the default fit against the noise-free truth of the
    six PMSM bench impedances (401 points, 1 kHz-10 MHz, 0.5 % complex noise per point,
    generated as scripts/make_testbench.py does)."""
    import numpy as np

    from benches.truth import (
        BENCH_VARIANTS,
        build_truth_network,
        lubricant_at_speed,
        truth_detail,
        truth_params,
    )
    from vfmodel.core.frequency_data import FrequencyData
    from vfmodel.fitting.vectfit import vector_fit
    from vfmodel.greybox.assembly import TOPOLOGY_PORTS

    print("seed topology order  per-point RMS vs truth  max vs truth  RMS vs data  "
          "(uniform weighting: RMS vs truth)")
    worst = 0.0
    for seed in seeds:
        r_truth, r_detail, r_imp, _ = (np.random.default_rng(x)
                                       for x in np.random.SeedSequence(seed).spawn(4))
        tp = truth_params(r_truth, 0.0)
        det = truth_detail(r_detail, n_coils=4, n_rungs=6)
        p0, st0 = lubricant_at_speed(tp, 0.0)
        net = build_truth_network(p0, det, BENCH_VARIANTS["paper"], st0)
        f = np.logspace(3, 7, 401)
        pairs = [TOPOLOGY_PORTS[t] for t in TOPOLOGY_PORTS]
        zz = net.mna.response(f, pairs, pairs)
        for i, topo in enumerate(TOPOLOGY_PORTS):
            z = zz[:, i, i]
            noisy = z + 0.005 * np.abs(z) * (r_imp.standard_normal(f.size)
                                             + 1j * r_imp.standard_normal(f.size)) / np.sqrt(2)
            data = FrequencyData(f, noisy, kind="Z")
            model, rep_ = vector_fit(data)
            e = np.abs(model(f)[:, 0, 0] - z) / np.abs(z)
            uni, _ = vector_fit(data, weighting="uniform")
            eu = np.abs(uni(f)[:, 0, 0] - z) / np.abs(z)
            rms = float(np.sqrt(np.mean(e**2)))
            worst = max(worst, rms)
            print(f"{seed:4d} {topo:8s} {model.n_poles:5d}  {100 * rms:10.3f} %  "
                  f"{100 * e.max():14.3f} %  {100 * rep_.point_rel_rms_error:9.3f} %  "
                  f"{100 * float(np.sqrt(np.mean(eu**2))):12.3f} %", flush=True)
    print(f"largest per-point RMS error against the truth: {100 * worst:.3f} %")


def _files(extra: list[str], pattern: str | None) -> list[Path]:
    import fnmatch

    import skrf

    skrf_data = Path(skrf.__file__).parent / "data"
    out = sorted(p for p in skrf_data.iterdir() if p.suffix.lower()[:2] == ".s")
    out += sorted(p for p in (ROOT / "data" / "vfbench").iterdir()
                  if p.suffix.lower()[:2] == ".s" and p.suffix.lower().endswith("p"))
    for d in extra:
        out += sorted(Path(x) for x in glob.glob(str(Path(d) / "*.[sS]*[pP]")))
    if pattern:
        out = [p for p in out if fnmatch.fnmatch(p.name, pattern)]
    return out


def _dense_sigma(model: Any, f_data: Any) -> float:
    """Largest singular value of an S model on an independent dense grid (module doc)."""
    import numpy as np

    pos = f_data[f_data > 0]
    grid = np.concatenate([[0.0], f_data,
                           np.geomspace(pos[0] * 1e-4, pos[-1] * 1e4, 200_000)])
    worst = 0.0
    for k in range(0, grid.size, 8192):
        h = model(grid[k:k + 8192])
        worst = max(worst, float(np.max(np.linalg.svd(h, compute_uv=False)[:, 0])))
    return worst


def _median_time(fn: Any, runs: int) -> tuple[Any, float]:
    times, out = [], None
    for _ in range(runs):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, statistics.median(times)


class Overtime(Exception):
    """A scikit-rf fit ran beyond its time limit (the file is shown, not timed)."""


@contextlib.contextmanager
def time_limit(seconds: float, what: str) -> Iterator[None]:
    """Raise :class:`Overtime` in the block after ``seconds`` (SIGALRM: main thread)."""
    def _stop(signum: int, frame: Any) -> None:
        raise Overtime(f"{what} ran beyond {seconds:g} s")

    old = signal.signal(signal.SIGALRM, _stop)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _skrf_case(net: Any, runs: int, passive: bool, f: Any, h: Any, limit: float
               ) -> dict[str, Any]:
    import numpy as np
    import skrf

    def fit() -> Any:
        vf = skrf.vectorFitting.VectorFitting(net)
        vf.auto_fit()
        return vf

    from benches.skrf_reference import skrf_order, skrf_response

    def resp(vf: Any) -> Any:
        return skrf_response(vf, f)

    with time_limit(limit * runs, "scikit-rf's auto_fit"):
        vf, t = _median_time(fit, runs)
    row: dict[str, Any] = {
        "order": skrf_order(vf),
        "err": float(np.linalg.norm(resp(vf) - h) / np.linalg.norm(h)), "time": t,
    }
    if passive:
        try:
            if not vf.is_passive():
                vf.passivity_enforce()
            row["err_pas"] = float(np.linalg.norm(resp(vf) - h) / np.linalg.norm(h))
            row["pas"] = bool(vf.is_passive())
        except Exception as err:
            row["note"] = f"passivity_enforce: {type(err).__name__}"
    return row


def _vf_case(path: Path, runs: int) -> dict[str, Any]:
    import numpy as np

    from vfmodel import read_spectrum
    from vfmodel.errors import InputError, VfmodelError
    from vfmodel.fitting.data_passivity import data_passivity
    from vfmodel.fitting.vectfit import fit_errors, vector_fit
    from vfmodel.pipeline.fit_job import run_fit

    row: dict[str, Any] = {}
    try:
        data = read_spectrum(path).to_kind("S")
        row["ports"], row["points"] = data.n_out, data.n_freq
        small = data.n_out <= _SMALL[0] and data.n_freq <= _SMALL[1]
        res, t = _median_time(lambda: run_fit([data], delay="auto"), runs if small else 1)
        (_, t_fit) = _median_time(lambda: vector_fit(res.data, delay="auto"),
                                  runs if small else 1)
        row.update(order=res.model.n_poles, err=res.rel_rms_error, time=t_fit,
                   small=small, job_time=t)
        dp = data_passivity(res.data)
        row["floor"] = dp.floor if dp is not None else None
        row["model_data"] = (res.data.freq_hz, res.data.values, res.data.z0)
        if dp is not None and dp.active:
            row["note"] = f"active data (floor {dp.floor:.2g}): enforcement refused"
            return row
        model, check = res.model, res.passivity
        if check is not None and not check.passive:  # as `vfmodel fit --passive` does
            enf = run_fit([data], passive=True, delay="auto")
            model, check = enf.model, enf.passivity
        row["err_pas"] = fit_errors(model, res.data)[1]
        row["cert"] = bool(check is not None and check.passive)
        row["sigma"] = _dense_sigma(model, res.data.freq_hz)
        row["pas"] = row["sigma"] <= 1 + 1e-9
        del np
    except InputError as err:
        row["note"] = f"refused (exit 2): {str(err).split(': ', 1)[-1][:70]}"
    except VfmodelError as err:
        row["note"] = f"FAILED: {type(err).__name__}: {str(err)[:60]}"
    except Exception as err:
        row["note"] = f"INTERNAL ERROR: {type(err).__name__}: {str(err)[:60]}"
    return row


def _fmt(x: Any, spec: str = ".2e") -> str:
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "NO"
    return format(x, spec)


def main() -> int:
    args = _args()
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    import numpy as np
    import skrf

    sys.path.insert(0, str(ROOT))
    warnings.simplefilter("ignore")
    if args.impedance_seeds:
        lo, _, hi = args.impedance_seeds.partition("-")
        _impedance_truth(list(range(int(lo), int(hi or lo) + 1)))
        return 0
    cols = ["file", "ports", "points", "order vf/skrf", "error vf", "error skrf",
            "time vf s", "time skrf s", "floor", "err pas vf", "err pas skrf",
            "passive vf (cert)", "passive skrf", "note"]
    sep = " | " if args.markdown else "  "
    if args.markdown:
        print("| " + sep.join(cols) + " |")
        print("|" + "---|" * len(cols))
    else:
        print(sep.join(cols))
    stats: dict[str, list[Any]] = {"ratio_err": [], "small_t": [], "enf": [], "bad": []}
    for path in _files(args.extra, args.files):
        vf = _vf_case(path, args.runs)
        sk: dict[str, Any] = {}
        md = vf.pop("model_data", None)
        if md is not None:
            try:
                net = skrf.Network(str(path))
                if not np.allclose(net.z0, md[2]):  # vfmodel renormalised: the same data
                    net.renormalize(md[2])
                runs = args.runs if vf.get("small") else 1
                sk = _skrf_case(net, runs, not args.no_skrf_passive, md[0], md[1],
                                args.skrf_limit)
            except Exception as err:
                sk = {"note": f"skrf: {type(err).__name__}: {str(err)[:50]}"}
        if "err" in vf and "err" in sk:
            stats["ratio_err"].append((path.name, vf["err"], sk["err"]))
        if vf.get("small") and "time" in sk:
            stats["small_t"].append((vf["time"], sk["time"]))
        if "err_pas" in vf:
            bound = max(vf["err"], vf["floor"] or 0.0)
            stats["enf"].append((path.name, vf["err_pas"], bound))
        note = vf.get("note", "")
        if "INTERNAL" in note or "FAILED" in note or vf.get("pas") is False:
            stats["bad"].append(path.name)
        cells = [path.name, _fmt(vf.get("ports"), "d"), _fmt(vf.get("points"), "d"),
                 f"{_fmt(vf.get('order'), 'd')}/{_fmt(sk.get('order'), 'd')}",
                 _fmt(vf.get("err")), _fmt(sk.get("err")), _fmt(vf.get("time"), ".3f"),
                 _fmt(sk.get("time"), ".3f"), _fmt(vf.get("floor"), ".1e"),
                 _fmt(vf.get("err_pas")), _fmt(sk.get("err_pas")),
                 f"{_fmt(vf.get('pas'))} ({_fmt(vf.get('cert'))})", _fmt(sk.get("pas")),
                 "; ".join(x for x in (vf.get("note", ""), sk.get("note", "")) if x)]
        line = sep.join(cells)
        print(f"| {line} |" if args.markdown else line, flush=True)
    _summary(stats)
    return 0


def _summary(stats: dict[str, list[Any]]) -> None:
    import numpy as np

    r = stats["ratio_err"]
    ok = [n for n, a, b in r if a <= 1.1 * b or a < 1e-9]
    print(f"\nerror <= 1.1 x scikit-rf's (or < 1e-9): {len(ok)} of {len(r)} files both fit")
    if stats["small_t"]:
        tv, ts = np.median([a for a, _ in stats["small_t"]]), np.median(
            [b for _, b in stats["small_t"]])
        print(f"small files ({len(stats['small_t'])}): median fit time vfmodel {tv:.4f} s, "
              f"scikit-rf {ts:.4f} s")
    enf = stats["enf"]
    within = [n for n, e, b in enf if e <= 1.2 * b]
    print(f"enforced error <= 1.2 x max(fit error, data floor): {len(within)} of {len(enf)}; "
          "beyond: " + ", ".join(f"{n} ({e / max(b, 1e-300):.3g}x)" for n, e, b in enf
                                 if n not in within))
    print("exit-1 failures (internal or solver errors) or enforced models failing the dense "
          "check: "
          + (", ".join(stats["bad"]) or "none"))


if __name__ == "__main__":
    raise SystemExit(main())
