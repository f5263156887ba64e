"""Benchmark: scikit-rf ``VectorFitting.passivity_enforce`` vs vfmodel ``enforce_passivity``
on the same S models (fitted by vfmodel.vector_fit), in one run.

Usage::

    .venv/bin/python scripts/bench_passivity.py [--order N] [FILE.sNp ...]

Default files: data/touchstone/*.s4p, fitted with ``order="auto"`` (or ``--order N``)
on the samples that are data, as the fit job does: export padding dropped, isolated spikes
given zero weight (:func:`vfmodel.fitting.artifacts.find_artifacts`; the CST file has both).
Errors count the spikes; the "clean" figures leave them out.
For each file and each tool: time, RMS error against the data after enforcement, and
whether the result is certified passive by the vfmodel Hamiltonian test (and by 1e5-point
sampling of sigma_max). The "floor" line is the smallest RMS change any passive response
must make to the data itself: the RMS of clipping the data's singular values to 1.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np
import skrf

import vfmodel
from vfmodel import FrequencyData, RationalModel, check_passivity, enforce_passivity
from vfmodel.fitting.artifacts import find_artifacts
from vfmodel.fitting.vectfit import fit_errors

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = sorted((ROOT / "data" / "touchstone").glob("*.s?p"))


def to_skrf(model: RationalModel, net: skrf.Network) -> skrf.vectorFitting.VectorFitting:
    """A scikit-rf VectorFitting holding ``model`` (upper poles only, responses i*n+j)."""
    vf = skrf.vectorFitting.VectorFitting(net)
    keep = model.poles.imag >= 0
    n = model.n_in
    vf.poles = model.poles[keep]
    vf.residues = model.residues[keep].reshape(int(keep.sum()), n * n).T.copy()
    vf.constant_coeff = model.dd.reshape(n * n).copy()
    vf.proportional_coeff = model.ee.reshape(n * n).copy()
    return vf


def from_skrf(vf: skrf.vectorFitting.VectorFitting, n: int, z0: float | None) -> RationalModel:
    poles, res = [], []
    for k, p in enumerate(vf.poles):
        r = vf.residues[:, k].reshape(n, n)
        poles.append(p)
        res.append(r)
        if p.imag > 0:
            poles.append(np.conj(p))
            res.append(np.conj(r))
    return RationalModel(
        poles=np.array(poles),
        residues=np.array(res),
        d=vf.constant_coeff.reshape(n, n),
        e=vf.proportional_coeff.reshape(n, n),
        kind="S",
        z0=z0,
    )


def passive_floor(data: FrequencyData) -> float:
    """RMS change of the data when its singular values are clipped to 1."""
    u, sv, vh = np.linalg.svd(data.values)
    clipped = u @ (np.minimum(sv, 1.0)[..., None] * vh)
    return float(np.sqrt(np.mean(np.abs(clipped - data.values) ** 2)))


def sampled_passive(model: RationalModel, data: FrequencyData) -> bool:
    f = np.linspace(0.0, 3 * data.freq_hz[-1], 100_000)
    return bool(np.linalg.svd(model(f), compute_uv=False)[:, 0].max() <= 1 + 1e-12)


def main(paths: list[Path], order: int | str) -> None:
    print(f"{'file':28s} {'tool':8s} {'time_s':>8s} {'rms':>10s} {'rms/fit':>8s} certified")
    for path in paths:
        net = skrf.Network(str(path))
        data = FrequencyData.from_network(net, kind="S", source=path.name)
        art = find_artifacts(data)
        if art.found:
            print(f"{path.name:28s} artifacts: {art.describe()}")
            k = art.n_genuine
            data = FrequencyData(data.freq_hz[:k], data.values[:k], kind="S", z0=data.z0)
            net = data.to_network()
        ok = np.setdiff1d(np.arange(data.n_freq), art.spikes)
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model, fit = vfmodel.vector_fit(  # type: ignore[arg-type]
                data, order=order, exclude=art.spikes or None
            )
        t_fit = time.perf_counter() - t0

        def clean(
            m: RationalModel, data: FrequencyData = data, ok: np.ndarray = ok
        ) -> str:
            err = m(data.freq_hz[ok]) - data.values[ok]
            return f"clean rms {float(np.sqrt(np.mean(np.abs(err) ** 2))):.3g}"
        print(f"{path.name:28s} {'floor':8s} {'':>8s} {passive_floor(data):10.4g}")
        before = check_passivity(model)
        print(
            f"{path.name:28s} {'fit':8s} {t_fit:8.2f} {fit.rms_error:10.4g} {1.0:8.3f} "
            f"{before.passive} (order {model.n_poles}, rel {fit.rel_rms_error:.4g}, "
            f"sigma_max(D) {np.linalg.norm(model.dd, 2):.3g}, worst "
            f"{before.worst_violation:.3g}, {clean(model)})"
        )
        # scikit-rf
        vf = to_skrf(model, net)
        t0 = time.perf_counter()
        status = "ok"
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                vf.passivity_enforce()
        except Exception as err:  # report, never hide
            status = f"error: {type(err).__name__}: {err}"
        t_skrf = time.perf_counter() - t0
        sk_model = from_skrf(vf, model.n_in, model.z0)
        rms = fit_errors(sk_model, data)[0]
        try:
            cert = f"{check_passivity(sk_model).passive}/{sampled_passive(sk_model, data)}"
        except Exception as err:  # report, never hide
            cert = f"check failed: {err}"
        print(
            f"{'':28s} {'skrf':8s} {t_skrf:8.2f} {rms:10.4g} {rms / fit.rms_error:8.3f} "
            f"{cert} {clean(sk_model)} {'' if status == 'ok' else status}"
        )
        # vfmodel
        t0 = time.perf_counter()
        try:
            fixed, rep = enforce_passivity(model, data, weighting="uniform")
            t_vf = time.perf_counter() - t0
            rms = fit_errors(fixed, data)[0]
            print(
                f"{'':28s} {'vfmodel':8s} {t_vf:8.2f} {rms:10.4g} {rms / fit.rms_error:8.3f} "
                f"{rep.passive}/{sampled_passive(fixed, data)} ({rep.iterations} programs, "
                f"rel {fit_errors(fixed, data)[1]:.4g}, {clean(fixed)})"
            )
        except vfmodel.errors.VfmodelError as err:
            t_vf = time.perf_counter() - t0
            print(f"{'':28s} {'vfmodel':8s} {t_vf:8.2f} failed: {err}")
        sys.stdout.flush()


if __name__ == "__main__":
    args = sys.argv[1:]
    order: int | str = "auto"
    if args[:1] == ["--order"]:
        order, args = int(args[1]), args[2:]
    main([Path(a) for a in args] or DEFAULT, order)
