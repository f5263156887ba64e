"""Benchmark: scikit-rf ``VectorFitting.passivity_enforce`` vs vfmodel ``enforce_passivity``
on the same S models (fitted by vfmodel.vector_fit), in one run.

Usage::

    .venv/bin/python scripts/bench_passivity.py [FILE.sNp ...]

Default files: data/touchstone/*.s4p. For each file and each tool: time, RMS error
against the data after enforcement, and whether the result is certified passive by the
vfmodel Hamiltonian test.
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


def main(paths: list[Path]) -> None:
    print(f"{'file':28s} {'tool':8s} {'time_s':>8s} {'rms':>10s} {'rms/fit':>8s} certified")
    for path in paths:
        net = skrf.Network(str(path))
        data = FrequencyData.from_network(net, kind="S", source=path.name)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model, fit = vfmodel.vector_fit(data, order="auto")
        before = check_passivity(model)
        print(
            f"{path.name:28s} {'fit':8s} {'':>8s} {fit.rms_error:10.4g} {1.0:8.3f} "
            f"{before.passive} (order {model.n_poles}, worst {before.worst_violation:.3g})"
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
            cert = check_passivity(sk_model).passive
        except Exception as err:
            cert = f"check failed: {err}"  # type: ignore[assignment]
        print(
            f"{'':28s} {'skrf':8s} {t_skrf:8.2f} {rms:10.4g} {rms / fit.rms_error:8.3f} "
            f"{cert} {'' if status == 'ok' else status}"
        )
        # vfmodel
        t0 = time.perf_counter()
        try:
            fixed, rep = enforce_passivity(model, data)
            t_vf = time.perf_counter() - t0
            rms = fit_errors(fixed, data)[0]
            print(
                f"{'':28s} {'vfmodel':8s} {t_vf:8.2f} {rms:10.4g} {rms / fit.rms_error:8.3f} "
                f"{rep.passive} ({rep.iterations} programs)"
            )
        except vfmodel.errors.VfmodelError as err:
            t_vf = time.perf_counter() - t0
            print(f"{'':28s} {'vfmodel':8s} {t_vf:8.2f} failed: {err}")
        sys.stdout.flush()


if __name__ == "__main__":
    main([Path(a) for a in sys.argv[1:]] or DEFAULT)
