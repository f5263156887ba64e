"""Passivity enforcement by residue (and D) perturbation: the convex program.

For fixed poles the response is linear in the residues and D, and both passivity conditions
are convex in H at a fixed frequency:

- Z, Y: the Hermitian part P = (H + H^H)/2 must be PSD; for an n-port we impose the real
  symmetric embedding [[Re P, -Im P], [Im P, Re P]] >= eps I (same eigenvalues as P, twice);
- S: ||H||_2 <= 1 - eps, i.e. [[I, R(H)], [R(H)^T, I]] >= 0 with R(H) = [[Re H, -Im H],
  [Im H, Re H]] (same singular values as H).

The perturbation dH(s) = sum_k dR_k phi_k(s) + dD uses a real basis that keeps conjugate
pairs conjugate: phi = 1/(s - p) for a real pole; 1/(s - p) + 1/(s - p*) and
j/(s - p) - j/(s - p*) for the real and imaginary parts of the upper residue of a pair.
The objective, the weighted change of H on the data frequencies, is the sum over entries
(i, j) of ||W_ij Phi x_ij||^2 = ||R_ij x_ij||^2 where Phi = QR: R_ij is square, so the
program size does not grow with the number of data frequencies.

The constraints are exact at the constraint frequencies; the program is re-solved from the
original model with more constraint frequencies (cutting planes) until the Hamiltonian test
finds no violation band.

References
----------
.. [1] B. Gustavsen, A. Semlyen, "Enforcing passivity for admittance matrices approximated by
   rational functions", IEEE Trans. Power Syst. 16(1) (2001), doi:10.1109/59.910780.
.. [2] C. P. Coelho, J. Phillips, L. M. Silveira, "A convex programming approach for generating
   guaranteed passive approximations to tabulated frequency-data", IEEE Trans. CAD 23(2)
   (2004), doi:10.1109/TCAD.2003.822107.
.. [3] S. Grivet-Talocia, B. Gustavsen, "Passive Macromodeling", Wiley (2016),
   doi:10.1002/9781119140931.
"""

from __future__ import annotations

import warnings
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from scipy import sparse

from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import InputError, PassivityError, SolverError
from vfmodel.fitting.passivity import PassivityReport, check_passivity

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

_INTERIOR = 8  # constraint points inside each violation band
# Objective forms (norm or its square) and Clarabel settings tried in turn until one ends
# "optimal": tolerances a little looser
# than the 1e-8 defaults, then variants that cure the stalls ("AlmostSolved") seen with the
# structurally degenerate PSD constraints (the real embedding doubles every eigenvalue).
# The result is certified by the Hamiltonian test, not by the solver.
_TIKHONOV = 1e-4
_TOL = {"tol_gap_abs": 1e-7, "tol_gap_rel": 1e-7, "tol_feas": 1e-7}
_ATTEMPTS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("norm", _TOL),
    ("norm", {**_TOL, "max_step_fraction": 0.95}),
    ("sumsq", {}),
    ("norm", {**_TOL, "static_regularization_constant": 1e-7}),
    ("sumsq", {**_TOL, "static_regularization_constant": 1e-7}),
    ("norm", {**_TOL, "equilibrate_enable": False}),
    # last resort: 1e-6 tolerances (the Hamiltonian test still certifies the result)
    ("norm", {"tol_gap_abs": 1e-6, "tol_gap_rel": 1e-6, "tol_feas": 1e-6}),
    ("sumsq", {"tol_gap_abs": 1e-6, "tol_gap_rel": 1e-6, "tol_feas": 1e-6}),
)


def _basis(poles: ComplexArray, s: NDArray[np.complexfloating], with_d: bool) -> ComplexArray:
    """Real-parameter basis (n_s, n_b) of the perturbation (see module docstring)."""
    cols: list[ComplexArray] = []
    k = 0
    while k < poles.size:
        p = poles[k]
        if p.imag == 0:
            cols.append(1.0 / (s - p))
            k += 1
        else:
            a, b = 1.0 / (s - p), 1.0 / (s - np.conj(p))
            cols += [a + b, 1j * (a - b)]
            k += 2
    if with_d:
        cols.append(np.ones_like(s))
    return np.column_stack(cols) if cols else np.zeros((s.size, 0), complex)


def _to_residues(
    poles: ComplexArray, x: FloatArray, n: int
) -> tuple[ComplexArray, FloatArray]:
    """Residue and D perturbations from the real parameters x (n_b, n, n)."""
    dr = np.zeros((poles.size, n, n), complex)
    k = j = 0
    while k < poles.size:
        if poles[k].imag == 0:
            dr[k] = x[j]
            k, j = k + 1, j + 1
        else:
            dr[k] = x[j] + 1j * x[j + 1]
            dr[k + 1] = np.conj(dr[k])
            k, j = k + 2, j + 2
    dd = x[j] if j < x.shape[0] else np.zeros((n, n))
    return dr, np.asarray(dd, dtype=float)


def _band_points(bands: tuple[tuple[float, float], ...], worst: float | None) -> FloatArray:
    """Constraint frequencies (Hz) for violation bands: edges, interior, just outside."""
    pts: list[float] = []
    for lo, hi in bands:
        if not np.isfinite(hi):
            top = max(lo, 1.0) * 1e3
            pts += list(np.logspace(np.log10(max(lo, 1.0)), np.log10(top), 3 * _INTERIOR))
            continue
        a = lo if lo > 0 else hi * 1e-3
        # at least _INTERIOR points, and 8 per decade in broad bands
        count = max(_INTERIOR, int(8 * np.log10(hi / a))) + 2
        pts += list(np.logspace(np.log10(a), np.log10(hi), count))
        pts += [hi * 1.02] + ([lo * 0.98] if lo > 0 else [0.0])
    if worst is not None and np.isfinite(worst):
        pts.append(worst)
    return np.asarray(pts, dtype=float)


def _embed(kind: str, hr: FloatArray, hi: FloatArray) -> FloatArray:
    """Real symmetric matrix, linear in (Re H, Im H), whose PSD-ness (plus an offset) is the
    passivity condition: Z, Y: [[Pr, -Pi], [Pi, Pr]] with P = (H + H^H)/2; S: the off-diagonal
    blocks of [[I, R], [R^T, I]] with R = [[Re H, -Im H], [Im H, Re H]]."""
    if kind == "S":
        r = np.block([[hr, -hi], [hi, hr]])
        z = np.zeros_like(r)
        return np.block([[z, r], [r.T, z]])
    pr = 0.5 * (hr + hr.T)
    pi = 0.5 * (hi - hi.T)
    return np.block([[pr, -pi], [pi, pr]])


def _dedupe(f_hz: FloatArray, rel: float = 1e-7) -> FloatArray:
    """Sorted frequencies without near-duplicates (which make the program degenerate)."""
    f = np.unique(f_hz)
    if f.size < 2:
        return f
    keep = np.concatenate([[True], np.diff(f) > rel * f[1:]])
    return f[keep]


def enforce(
    model: RationalModel,
    data: FrequencyData | None,
    *,
    weighting: Literal["relative", "uniform"],
    perturb_d: bool,
    max_iter: int,
    margin: float,
) -> tuple[RationalModel, PassivityReport]:
    """Implementation of :func:`vfmodel.fitting.passivity.enforce_passivity`."""
    if weighting not in ("relative", "uniform"):
        raise InputError(
            "weighting: unknown choice", found=repr(weighting), expected="relative, uniform"
        )
    if max_iter < 1:
        raise InputError("max_iter must be >= 1", found=str(max_iter))
    first = check_passivity(model, method="hamiltonian")
    if not first.stable:
        raise PassivityError(
            "cannot enforce passivity of an unstable model (poles with Re(p) >= 0); "
            "refit with stable poles"
        )
    notes: list[str] = []
    e = model.ee
    if model.kind == "S" and np.any(e != 0):
        raise PassivityError("an S model with E != 0 cannot be bounded real; refit with E = 0")
    if model.kind != "S" and not first.e_ok:
        # nearest symmetric PSD matrix (Frobenius): clip the eigenvalues of the symmetric part
        lam, vec = np.linalg.eigh(0.5 * (e + e.T))
        e = (vec * np.clip(lam, 0, None)) @ vec.T
        notes.append("E replaced by its nearest symmetric PSD matrix")
        model = RationalModel(model.poles, model.residues, model.dd, e, model.kind, model.z0)
        first = check_passivity(model, method="hamiltonian")
    if first.passive:
        return model, first

    n = model.n_in
    if data is None:
        mags = np.abs(model.poles[np.abs(model.poles) > 0])
        lo, hi = (mags.min(), mags.max()) if mags.size else (1.0, 1.0)
        f = np.logspace(np.log10(lo / 10), np.log10(hi * 10), 400) / (2 * np.pi)
        h_data = model(f)
    else:
        if not isinstance(data, FrequencyData):
            raise InputError("data must be FrequencyData", found=type(data).__name__)
        data = data.to_kind(model.kind, model.z0) if data.kind != model.kind else data
        if data.n_in != n or data.n_out != n:
            raise InputError(
                "data and model port counts differ",
                source=data.source,
                found=f"{data.n_out}x{data.n_in}",
                expected=f"{n}x{n}",
            )
        f, h_data = data.freq_hz, data.values
    s_data = 2j * np.pi * f
    h0 = 1.0 if model.kind == "S" else float(np.sqrt(np.mean(np.abs(h_data) ** 2)))
    h0 = h0 if h0 > 0 else 1.0

    # weights (n_f, n, n) and the QR-reduced objective per entry
    if weighting == "relative":
        mag = np.abs(h_data)
        floor = 1e-3 * np.max(mag, axis=(1, 2), keepdims=True)
        wts = 1.0 / np.maximum(mag, np.maximum(floor, 1e-300))
    else:
        wts = np.full(h_data.shape, 1.0 / h0)
    wts = wts / np.sqrt(f.size)
    phi_d = _basis(model.poles, s_data, perturb_d)
    col = np.max(np.abs(phi_d), axis=0)  # column scaling: x in units of the response
    col = np.where(col > 0, col, 1.0)
    phi_d = phi_d / col
    n_b = phi_d.shape[1]
    r_mats: list[FloatArray] = []
    for i in range(n):
        for j in range(n):
            a = wts[:, i, j, None] * phi_d * h0
            # small Tikhonov term: keeps directions the data barely sees (poles outside
            # the data band) from taking huge values and the program well conditioned
            a_ri = np.vstack([a.real, a.imag])
            reg = _TIKHONOV * np.linalg.norm(a_ri, 2) * np.eye(n_b)
            r_mats.append(np.asarray(np.linalg.qr(np.vstack([a_ri, reg]), mode="r"), dtype=float))

    h_model_data = model(f)
    cons_hz = _dedupe(_band_points(first.bands_hz, first.worst_freq_hz))
    report = first
    for it in range(1, max_iter + 1):
        x_val = _solve(model, cons_hz, r_mats, col, h0, n_b, perturb_d, margin)
        dr, dd = _to_residues(model.poles, x_val * h0 / col[:, None, None], n)
        new = RationalModel(
            model.poles, model.residues + dr, model.dd + dd, e, model.kind, model.z0
        )
        report = check_passivity(new, method="hamiltonian")
        if report.passive:
            dh = new(f) - h_model_data
            rms = float(np.sqrt(np.mean(np.abs(dh) ** 2)))
            rel = float(np.linalg.norm(dh)) / max(float(np.linalg.norm(h_data)), 1e-300)
            final = PassivityReport(
                **{
                    **report.__dict__,
                    "iterations": it,
                    "rms_change": rms,
                    "rel_rms_change": rel,
                    "notes": tuple(notes) + report.notes,
                }
            )
            return new, final
        extra = _band_points(report.bands_hz, report.worst_freq_hz)
        cons_hz = _dedupe(np.concatenate([cons_hz, extra]))
    raise PassivityError(
        f"passivity not certified after {max_iter} convex programs; last violation "
        f"{report.worst_violation:.3g} in bands {report.bands_hz[:3]} Hz; "
        "raise max_iter or the margin"
    )


def _solve(
    model: RationalModel,
    cons_hz: FloatArray,
    r_mats: list[FloatArray],
    col: FloatArray,
    h0: float,
    n_b: int,
    perturb_d: bool,
    margin: float,
) -> FloatArray:
    """One convex program; returns the scaled parameters x (n_b, n, n)."""
    import cvxpy
    n = model.n_in
    x = cvxpy.Variable((n_b, n * n))
    xv = cvxpy.vec(x, order="F")  # index b + n_b * (i * n + j)
    # minimise the 2-norm (same minimiser as its square; a second-order cone is better
    # conditioned for the interior-point solver than a quadratic objective)
    objective = cvxpy.norm(sparse.block_diag(r_mats, format="csr") @ xv, 2)
    s_c = 2j * np.pi * cons_hz
    phi_c = _basis(model.poles, s_c, perturb_d) / col
    h_c = (model.evaluate_s(s_c) - s_c[:, None, None] * model.ee[None]) / h0
    n_c = cons_hz.size
    cons = []
    if n == 1 and model.kind != "S":
        # Re(h + dh) >= margin |h|, all frequencies at once
        size = np.maximum(np.abs(h_c[:, 0, 0]), 1e-300)
        cons.append((phi_c.real / size[:, None]) @ xv >= margin - h_c[:, 0, 0].real / size)
    elif n == 1:
        # |h + dh| <= 1 - margin: one second-order cone per frequency
        re = h_c[:, 0, 0].real + phi_c.real @ xv
        im = h_c[:, 0, 0].imag + phi_c.imag @ xv
        cons.append(
            cvxpy.SOC(np.full(n_c, 1.0 - margin), cvxpy.vstack([re, im]), axis=0)
        )
    else:
        # PSD matrix at frequency k: const_k + G_k @ xv, G_k = kron(patterns, phi_k) (the
        # embedding is linear in (Re H, Im H); unit perturbations give the patterns)
        m = _embed(model.kind, np.zeros((n, n)), np.zeros((n, n))).shape[0]
        units = np.eye(n * n).reshape(n * n, n, n)
        zero = np.zeros((n, n))
        pat_r = np.column_stack([_embed(model.kind, u, zero).ravel(order="F") for u in units])
        pat_i = np.column_stack([_embed(model.kind, zero, u).ravel(order="F") for u in units])
        if model.kind == "S":
            offset = (1.0 - margin) * np.eye(m)
            size = np.ones(n_c)
        else:
            offset = -margin * np.eye(m)
            # each frequency's condition is divided by |H| there (PSD is invariant under
            # positive scaling), so all constraints are O(1) for impedances over decades
            size = np.maximum(np.linalg.norm(h_c, 2, axis=(1, 2)), 1e-300)
        consts = np.concatenate(
            [
                (_embed(model.kind, h_c[k].real, h_c[k].imag) / size[k] + offset).ravel(
                    order="F"
                )
                for k in range(n_c)
            ]
        )
        g = sparse.vstack(
            [
                sparse.kron(pat_r, phi_c[k].real[None] / size[k])
                + sparse.kron(pat_i, phi_c[k].imag[None] / size[k])
                for k in range(n_c)
            ],
            format="csr",
        )
        mats = consts + g @ xv
        mm = m * m
        for k in range(n_c):
            cons.append(cvxpy.reshape(mats[k * mm : (k + 1) * mm], (m, m), order="F") >> 0)
    if perturb_d:
        d_new = model.dd / h0 + cvxpy.reshape(x[n_b - 1], (n, n), order="C")
        if model.kind == "S":
            cons.append(cvxpy.sigma_max(d_new) <= 1.0 - margin)
        elif n == 1:
            cons.append(d_new[0, 0] >= 0)
        else:
            cons.append(0.5 * (d_new + d_new.T) >> 0)
    statuses: list[str] = []
    problems: dict[str, Any] = {}
    for form, settings in _ATTEMPTS:
        if form not in problems:
            obj = objective if form == "norm" else cvxpy.sum_squares(objective.args[0])
            problems[form] = cvxpy.Problem(cvxpy.Minimize(obj), cons)
        prob = problems[form]
        try:
            with warnings.catch_warnings():
                # cvxpy warns on inaccurate solutions; the status is checked below
                warnings.simplefilter("ignore", UserWarning)
                prob.solve(solver=cvxpy.CLARABEL, **settings)
        except cvxpy.error.SolverError as err:
            statuses.append(f"error {err}")
            continue
        statuses.append(str(prob.status))
        if prob.status == cvxpy.OPTIMAL and x.value is not None:
            break
    else:
        raise SolverError(
            f"passivity program did not end with status 'optimal' (got {statuses}); "
            f"{cons_hz.size} constraint frequencies, {n_b * n * n} unknowns"
        )
    return np.asarray(x.value, dtype=float).reshape(n_b, n, n)
