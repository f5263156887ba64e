"""The compressed Gauss-Newton system of greybox.lsq.fit_log takes the steps of the full one."""

from __future__ import annotations

import numpy as np

from vfmodel.greybox.lsq import _Compressed, fit_log

M, N = 3000, 12


def _problem() -> tuple[object, object, np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(5)
    t = np.linspace(0.0, 1.0, M)
    xt = rng.uniform(-0.5, 1.5, N) + np.tile([0.0, 2.0, 0.0], N // 3)

    def model(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        out, jac = np.zeros(M), np.zeros((M, N))
        for k in range(N // 3):
            a, w, d = np.exp(x[3 * k:3 * k + 3])
            e, s, c = np.exp(-d * t), np.sin(w * t), np.cos(w * t)
            out += a * e * s
            jac[:, 3 * k:3 * k + 3] = np.stack([a * e * s, a * e * c * t * w,
                                                -a * e * s * t * d], axis=1)
        return out, jac

    y = model(xt)[0] + 0.01 * rng.standard_normal(M)
    x0 = xt + 0.3 * rng.standard_normal(N)
    return (lambda x: model(x)[0] - y), (lambda x: model(x)[1]), x0, xt - 3, xt + 3


def test_compressed_system_keeps_cost_gradient_and_gauss_newton_matrix() -> None:
    fun, jac, x0, _, _ = _problem()
    c = _Compressed(fun, jac, 0)  # type: ignore[arg-type]
    c.fun(x0)
    x1 = x0 + 0.05  # a point other than the one that set the basis
    f, j = fun(x1), jac(x1)  # type: ignore[operator]
    fc, jc = c.fun(x1), c.jac(x1)
    assert fc.shape == (2 * N + 1,) and jc.shape == (2 * N + 1, N)
    # references: the full residual and Jacobian; rounding-level agreement
    assert abs(fc @ fc - f @ f) <= 1e-12 * (f @ f)
    assert np.allclose(jc.T @ fc, j.T @ f, rtol=0, atol=1e-10 * np.abs(j.T @ f).max())
    assert np.allclose(jc.T @ jc, j.T @ j, rtol=0, atol=1e-10 * np.abs(j.T @ j).max())


def test_compressed_fit_follows_the_full_fit() -> None:
    fun, jac, x0, lo, hi = _problem()
    full = fit_log(fun, jac, x0, lo, hi, max_nfev=30, xtol=1e-10, ftol=1e-10,  # type: ignore[arg-type]
                   compress=False)
    short = fit_log(fun, jac, x0, lo, hi, max_nfev=30, xtol=1e-10, ftol=1e-10,  # type: ignore[arg-type]
                    compress=True)
    # reference: scipy's trust-region reflective solver on the full residual; the
    # trajectories agree to rounding (measured 6e-12 on a 50,000 x 30 case)
    assert full.nfev == short.nfev
    assert np.max(np.abs(full.x - short.x)) < 1e-8


def test_joint_gate_test_abandons_only_what_cannot_reach_the_gate() -> None:
    # greybox.identify._gate_test: the spectra misfit at accepted points (the start is
    # point 1); limit 1.1, 25 evaluations allowed
    from vfmodel.greybox.identify import _gate_test

    def run(misfits: list[float], nfev_per_step: int = 1) -> int | None:
        stop = _gate_test(lambda q: float(q), 1.1, 25)  # type: ignore[arg-type]
        for k, m in enumerate(misfits, start=1):
            if stop(m, k, k * nfev_per_step):  # type: ignore[arg-type]
                return k
        return None

    # stuck above the gate (bench 105's trace): abandoned at the second accepted step
    assert run([1.0, 1.175, 1.177, 1.177]) == 3
    # above the gate but falling fast enough to reach it in the evaluations left: kept
    # (at point 3: 1.30 - 0.05 * 22 < 1.1)
    assert run([1.0, 1.35, 1.30, 1.25, 1.20, 1.15, 1.10, 1.08]) is None
    # below the gate: never abandoned
    assert run([1.0, 1.05, 1.04, 1.06, 1.09]) is None
    # the same slow fall with few evaluations left: abandoned (1.30 - 0.05 * 1 > 1.1)
    assert run([1.0, 1.35, 1.30], nfev_per_step=8) == 3
