"""Passivity enforcement: certified by the Hamiltonian test and by dense sampling."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import vfmodel.fitting._enforce as enforce_mod
from tests._random_models import TWO_PI, random_nonpassive, ref_grid, ref_margin
from vfmodel import FrequencyData, RationalModel, check_passivity, enforce_passivity
from vfmodel.errors import PassivityError, SolverError
from vfmodel.fitting._qp import unsvec


def _certify_random(seed: int, cases: list[tuple[str, int, bool]]) -> None:
    rng = np.random.default_rng(seed)
    iterations = []
    for i, (kind, n, singular) in enumerate(cases):
        model = random_nonpassive(rng, kind, n, singular_d=singular)
        assert not check_passivity(model).passive
        fixed, report = enforce_passivity(model)
        assert report.passive and report.method == "hamiltonian" and report.iterations >= 1
        iterations.append(report.iterations)
        # independent certificate: 1e5-point dense sampling of the margin, which must be
        # >= 0 up to rounding (1e-12 of the response size)
        w = ref_grid(fixed)
        scale = 1.0 if kind == "S" else float(np.max(np.abs(fixed(w / TWO_PI))))
        assert ref_margin(fixed, w).min() >= -1e-12 * scale, (i, kind, n)
        # asymptotic conditions hold too
        assert report.asymptotic_ok and report.d_margin >= -1e-12 * scale
        # the model changed by the reported amount (on the default grid: model's own response)
        assert report.rms_change > 0
    assert max(iterations) <= 30


def test_enforcement_50_random_models_certified() -> None:
    # issue 4: 50 random non-passive models, Z, Y, S, 1-4 ports, every fifth with singular
    # D + D^T (Z, Y) resp. a unit singular value of D (S); about 20 s
    _certify_random(99, [("ZYS"[i % 3], 1 + (i // 3) % 4, i % 5 == 4) for i in range(50)])


def test_enforcement_keeps_data_fit_and_reports_rms_change() -> None:
    rng = np.random.default_rng(5)
    model = random_nonpassive(rng, "Z", 2)
    f = np.logspace(3, 7, 300)
    data = FrequencyData(f, model(f), kind="Z")
    fixed, report = enforce_passivity(model, data)
    dh = fixed(f) - model(f)
    assert report.rms_change == pytest.approx(np.sqrt(np.mean(np.abs(dh) ** 2)), rel=1e-12)
    assert report.rel_rms_change == pytest.approx(
        np.linalg.norm(dh) / np.linalg.norm(data.values), rel=1e-12
    )
    assert check_passivity(fixed).passive
    # poles are kept, only residues and D move
    np.testing.assert_array_equal(fixed.poles, model.poles)


def test_passive_model_is_returned_unchanged() -> None:
    model = RationalModel(poles=[-1e6], residues=[1e6], d=[[1.0]], kind="Z")
    fixed, report = enforce_passivity(model)
    assert fixed is model and report.passive and report.iterations == 0


def test_unstable_model_is_rejected() -> None:
    model = RationalModel(poles=[1e3], residues=[-1.0], d=[[1.0]], kind="Y")
    with pytest.raises(PassivityError, match="unstable"):
        enforce_passivity(model)


def test_solver_status_checked(monkeypatch: pytest.MonkeyPatch) -> None:
    # Clarabel stopped after one interior-point iteration cannot end "optimal", neither
    # on the direct program nor through the cvxpy fallback
    monkeypatch.setattr(enforce_mod, "_DIRECT", ({"max_iter": 1},))
    monkeypatch.setattr(enforce_mod, "_ATTEMPTS", (("norm", {"max_iter": 1}),))
    model = random_nonpassive(np.random.default_rng(3), "S", 2)
    with pytest.raises(SolverError, match="optimal"):
        enforce_passivity(model)


def test_iteration_limit_is_a_typed_error() -> None:
    rng = np.random.default_rng(11)
    for _ in range(20):  # find a model that needs more than one program
        model = random_nonpassive(rng, "Y", 3)
        _, report = enforce_passivity(model)
        if report.iterations > 1:
            break
    else:  # pragma: no cover
        pytest.fail("no model needing two programs found")
    with pytest.raises(PassivityError, match="not certified after 1"):
        enforce_passivity(model, max_iter=1)



def test_direct_program_matches_cvxpy(monkeypatch: pytest.MonkeyPatch) -> None:
    # the direct Clarabel program (the dual of the least-norm problem; the primal with
    # exact per-frequency cones) and the cvxpy formulation of the same constraints reach
    # the same minimum (1e-4 relative), feasibly
    for kind, seed in (("S", 5), ("Y", 6)):
        model = random_nonpassive(np.random.default_rng(seed), kind, 3)
        grabbed: list[tuple[Any, Any, Any]] = []
        orig = enforce_mod._solve

        def grab(setup: Any, a: Any, b: Any, scale: float = 1.0, psd: Any = (),
                 deadline: Any = None, _orig: Any = orig, _g: Any = grabbed) -> Any:
            _g.append((setup, a, b))
            return _orig(setup, a, b, scale=scale, psd=psd, deadline=deadline)

        monkeypatch.setattr(enforce_mod, "_solve", grab)
        enforce_passivity(model)
        monkeypatch.setattr(enforce_mod, "_solve", orig)
        setup, a, b = grabbed[0]
        worst = np.array([check_passivity(model).worst_freq_hz])
        cones = tuple(enforce_mod._cones(setup, worst, enforce_mod._response(model, worst),
                                         np.array([1e-6])))
        # scaled as the enforcement loop scales a program: by the objective of the one
        # before it (here the program without the cones). Unscaled (scale 1) the cone
        # program of the uniform weighting (objective 4e-4) stopped 1.7e-4 above cvxpy's
        # optimum, with the loop's scale 1e-8 from it
        scale = 1.0
        for psd in ((), cones):
            x_direct = orig(setup, a, b, scale=scale, psd=psd)
            x_cvx = enforce_mod._solve_cvxpy(setup, a, b, psd)
            scale = float(np.sum((setup.r_blocks @ x_direct) ** 2))
            obj_d = np.linalg.norm(setup.r_blocks @ x_direct)
            obj_c = np.linalg.norm(setup.r_blocks @ x_cvx)
            assert abs(obj_d - obj_c) <= 1e-4 * obj_c
            assert np.min(a @ x_direct - b) >= -1e-7
            for blk in psd:
                mat = unsvec(blk.k) @ (blk.b - blk.a @ x_direct)
                assert np.linalg.eigvalsh(mat.reshape(blk.k, blk.k))[0] >= -1e-7


def test_direct_program_finds_a_tiny_optimum() -> None:
    # a lossless model violating by 1e-9 needs a change of 1e-9: the least-norm point of
    # one cut a x >= b is b a / |a|^2 (analytic); with an S-type D condition (O(1) data,
    # inactive) beside it. Clarabel's gap test is relative to max(1, |objective|): unscaled,
    # "Solved" came at a change 1.6e4x the optimum (now within 1.5e-3).
    from scipy import sparse

    from vfmodel.fitting._qp import DConstraint, solve_qp

    rng = np.random.default_rng(3)
    n_b, n = 3, 1
    a = rng.standard_normal((1, n_b * n * n))
    b = np.array([1e-9])
    dc = DConstraint("S", np.array([[0.5]]), np.array([n_b - 1]), 1.0, 1.0 - 1e-6)
    x, status = solve_qp(sparse.identity(n_b, format="csr"), n_b, a, b, dc,
                         enforce_mod._DIRECT)
    assert x is not None and "Solved" in status
    x_opt = b[0] * a[0] / float(a[0] @ a[0])
    assert np.linalg.norm(x - x_opt) <= 1e-2 * np.linalg.norm(x_opt)


def test_tall_program_primal_equals_dual() -> None:
    # many more cuts than unknowns (enforce._PRIMAL_ROWS, _PRIMAL_TALL) are solved in the
    # primal form; it must reach the dual form's optimum (an S-type D condition beside)
    from scipy import sparse

    from vfmodel.fitting._qp import DConstraint, solve_qp

    rng = np.random.default_rng(7)
    n_b, n = 6, 2
    n_var = n_b * n * n
    rows = 4 * max(enforce_mod._PRIMAL_ROWS, int(enforce_mod._PRIMAL_TALL * n_var))
    a = rng.standard_normal((rows, n_var))
    b = rng.standard_normal(rows) - 3.0  # the origin violates a few of them
    assert np.min(b) < 0 < np.max(b)
    r_blocks = sparse.block_diag([np.triu(rng.standard_normal((n_b, n_b))) + 3 * np.eye(n_b)
                                  for _ in range(n * n)], format="csr")
    dc = DConstraint("S", np.diag([0.5, 0.3]), np.arange(n_b - 1, n_var, n_b), 1.0, 1 - 1e-6)
    x_p, st_p = solve_qp(r_blocks, n_b, a, b, dc, enforce_mod._PRIMAL, primal=True)
    x_d, st_d = solve_qp(r_blocks, n_b, a, b, dc, enforce_mod._DIRECT, primal=False)
    assert x_p is not None and x_d is not None and st_p[-1] == st_d[-1] == "Solved"
    assert np.min(a @ x_p - b) >= -1e-7
    obj_p, obj_d = np.linalg.norm(r_blocks @ x_p), np.linalg.norm(r_blocks @ x_d)
    assert abs(obj_p - obj_d) <= 1e-5 * obj_d
    assert np.linalg.norm(x_p - x_d) <= 1e-3 * np.linalg.norm(x_d)


def test_enforcement_reports_each_program() -> None:
    # a long enforcement is not silent: progress(stage, k, max_iter) before program k + 1,
    # and (max_iter, max_iter) once certified; as many programs as the report counts
    model = random_nonpassive(np.random.default_rng(5), "S", 3)
    calls: list[tuple[str, int, int]] = []
    _, rep = enforce_passivity(model, max_iter=30,
                               progress=lambda s, d, t: calls.append((s, d, t)))
    stages = {s for s, _, _ in calls}
    assert len(stages) == 1
    assert [(d, t) for _, d, t in calls] == [(k, 30) for k in range(rep.iterations)] + [(30, 30)]
