"""Passivity test and enforcement of rational Z, Y and S models.

A stable model is passive when

- Z, Y (positive real): the Hermitian part (H + H^H)/2 of H(j w) is positive semidefinite at
  every frequency, including the asymptotic conditions D + D^T PSD and E symmetric PSD;
- S (bounded real): every singular value of H(j w) is at most one, with sigma_max(D) <= 1
  and E = 0.

:func:`check_passivity` finds the violation bands exactly from the imaginary zeros of the
Popov function (Hamiltonian eigenvalues, see :mod:`vfmodel.fitting._hamiltonian`) and
classifies the intervals between them by evaluating the model; it falls back to dense
sampling when the eigenvalue problem fails. :func:`enforce_passivity` perturbs residues
(and D) in a convex program (cvxpy + Clarabel, :mod:`vfmodel.fitting._enforce`) until the
Hamiltonian test passes.

References
----------
.. [1] S. Boyd, V. Balakrishnan, P. Kabamba, Math. Control Signals Systems 2 (1989),
   doi:10.1007/BF02551387.
.. [2] B. Gustavsen, A. Semlyen, "Enforcing passivity for admittance matrices approximated by
   rational functions", IEEE Trans. Power Syst. 16(1) (2001), doi:10.1109/59.910778.
.. [3] S. Grivet-Talocia, B. Gustavsen, "Passive Macromodeling: Theory and Applications",
   Wiley (2016), doi:10.1002/9781119140931.
"""

from __future__ import annotations

import os
import time
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import brentq, minimize_scalar

from vfmodel.core.blas import capped_blas
from vfmodel.core.frequency_data import FrequencyData, as_frequency_data
from vfmodel.core.progress import Progress, no_progress
from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import InputError, PassivityError, PassivityWarning
from vfmodel.fitting._hamiltonian import crossing_frequencies, scaled_model
from vfmodel.fitting.defaults import ENFORCE_ITERATIONS

if TYPE_CHECKING:  # pragma: no cover
    import skrf

FloatArray = NDArray[np.float64]
CheckMethod = Literal["auto", "hamiltonian", "sampling"]

_CHUNK = 4096
_CROSS_CHECK = 3000  # log-spaced points of the sampling cross-check of a certificate
_NEAR_SPAN = np.linspace(-1e-2, 1e-2, 41)  # ... and around eigenvalues near the axis


@dataclass(frozen=True)
class PassivityReport:
    """Result of a passivity check (and of an enforcement, which ends with a check).

    Attributes
    ----------
    passive : bool
        True only when the model is stable, meets the asymptotic conditions and has no
        violation band (certified by the Hamiltonian test when ``method == "hamiltonian"``).
    stable : bool
        Every pole strictly in the left half plane.
    kind : str
        "Z", "Y" or "S".
    method : {"hamiltonian", "sampling"}
        How the bands were found.
    hamiltonian_form : {"standard", "pencil"} or None
        Hamiltonian matrix (D_p non-singular) or generalized pencil (singular D_p).
    bands_hz : tuple of (lo, hi)
        Violation bands in Hz; ``hi`` may be ``inf``.
    crossings_hz : tuple of float
        Frequencies where an eigenvalue of Re H crosses zero (Z, Y) or a singular value of
        H crosses one (S).
    worst_violation : float
        Largest violation, >= 0: ``-min eig((H + H^H)/2)`` (Z, Y) or ``sigma_max(H) - 1``
        (S), over frequency and at infinity; 0 when passive.
    worst_freq_hz : float or None
        Where the worst violation occurs (``inf`` for an asymptotic violation).
    asymptotic_ok : bool
        Z, Y: D + D^T PSD and E symmetric PSD; S: sigma_max(D) <= 1 and E = 0.
    d_margin : float
        Z, Y: min eig((D + D^T)/2); S: 1 - sigma_max(D).
    e_ok : bool
        Z, Y: E symmetric PSD; S: E = 0.
    iterations : int
        Enforcement iterations (convex programs solved); 0 for a plain check.
    rms_change : float
        RMS over data frequencies and entries of |H_new - H_old| (0 for a check).
    rel_rms_change : float
        ``||H_new - H_old||_F / ||H_data||_F`` over the data frequencies (0 for a check).
    notes : tuple of str
        Remarks (fallbacks, projections).
    min_margin : float or None
        Smallest passivity margin (:func:`passivity_margin`, plus the asymptotic margin
        ``d_margin``) found by the sampling cross-check: a dense log grid over the poles
        +- 3 decades, 0 Hz, every resonance and both sides of every band edge; negative
        means a violation. None when not sampled.
    """

    passive: bool
    stable: bool
    kind: str
    method: Literal["hamiltonian", "sampling"]
    hamiltonian_form: str | None
    bands_hz: tuple[tuple[float, float], ...]
    crossings_hz: tuple[float, ...]
    worst_violation: float
    worst_freq_hz: float | None
    asymptotic_ok: bool
    d_margin: float
    e_ok: bool
    iterations: int = 0
    rms_change: float = 0.0
    rel_rms_change: float = 0.0
    notes: tuple[str, ...] = ()
    min_margin: float | None = None

    def describe(self) -> str:
        """One line: "passive (certified)", or why not -- unstable poles, violation bands,
        an asymptotic violation (a model with no band can still violate at infinity:
        sigma_max(D) = 1 + 3e-13 for a lossless 4-port balun fitted to 8e-13) -- and the
        worst violation with its frequency."""
        if self.passive:
            return "passive (certified)" if self.method == "hamiltonian" else \
                "passive (sampled, not certified)"
        why = []
        if not self.stable:
            why.append("unstable poles")
        if self.bands_hz:
            n = len(self.bands_hz)
            why.append(f"{n} violation band{'s' if n > 1 else ''}")
        if not self.asymptotic_ok:
            if self.kind == "S":
                why.append("at infinity: " + (f"sigma_max(D) = 1 + {-self.d_margin:.3g}"
                                              if self.d_margin < 0 else "E is not 0"))
            else:
                why.append("at infinity: " + (
                    f"smallest eigenvalue of (D + D^T)/2 {self.d_margin:.3g}"
                    if self.d_margin < 0 else "E is not symmetric positive semidefinite"))
        if not why:
            why.append("a sampled violation")
        text = "NOT passive (" + "; ".join(why)
        if self.worst_violation > 0:
            f = self.worst_freq_hz
            where = "" if f is None else (" at infinity" if not np.isfinite(f)
                                          else f" at {f:.4g} Hz")
            text += f"; worst violation {self.worst_violation:.3g}{where}"
        return text + ")"

    def _repr_html_(self) -> str:
        """Compact summary in Jupyter (:mod:`vfmodel.report.notebook`)."""
        from vfmodel.report.notebook import passivity_html

        return passivity_html(self)

    def plot(self, ax: Any = None) -> Any:
        """Violation bands and crossings (matplotlib imported now); returns the axes."""
        from vfmodel.report.notebook import passivity_plot

        return passivity_plot(self, ax)


# ---------------------------------------------------------------------- margins
def _check_kind(model: RationalModel) -> None:
    if not isinstance(model, RationalModel):
        raise InputError(
            "model must be a RationalModel", found=type(model).__name__, expected="RationalModel"
        )
    if model.kind not in ("Z", "Y", "S"):
        raise InputError(
            "passivity is defined for Z, Y and S models only",
            source="model",
            found=f"kind {model.kind!r}",
            expected="'Z', 'Y' or 'S'",
        )
    if model.n_in != model.n_out:
        raise InputError("passivity needs a square model", found=f"{model.n_out}x{model.n_in}")


def passivity_margin(model: RationalModel, omega: ArrayLike) -> FloatArray:
    """Passivity margin at angular frequencies ``omega`` (rad/s), E excluded.

    Z, Y: smallest eigenvalue of (H + H^H)/2; S: 1 - largest singular value of H.
    Negative values are violations.
    """
    _check_kind(model)
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    out = np.empty(w.size)
    for k in range(0, w.size, _CHUNK):
        sl = slice(k, k + _CHUNK)
        s = 1j * w[sl]
        h = model.evaluate_s(s) - s[:, None, None] * model.ee[None]
        if model.kind == "S":
            out[sl] = 1.0 - np.linalg.svd(h, compute_uv=False)[:, 0]
        else:
            herm = 0.5 * (h + np.conj(np.swapaxes(h, 1, 2)))
            out[sl] = np.linalg.eigvalsh(herm)[:, 0]
    return out


def _asymptotics(model: RationalModel) -> tuple[bool, float, bool]:
    d, e = model.dd, model.ee
    if model.kind == "S":
        d_margin = 1.0 - float(np.linalg.norm(d, 2)) if d.size else 1.0
        e_ok = bool(np.all(e == 0))
        return d_margin >= 0 and e_ok, d_margin, e_ok
    d_margin = float(np.linalg.eigvalsh(0.5 * (d + d.T))[0])
    e_scale = max(float(np.max(np.abs(e))), 1e-300)
    e_sym = bool(np.max(np.abs(e - e.T)) <= 1e-12 * e_scale)
    e_ok = e_sym and float(np.linalg.eigvalsh(0.5 * (e + e.T))[0]) >= -1e-12 * e_scale
    return d_margin >= 0 and e_ok, d_margin, e_ok


def _scale(model: RationalModel) -> float:
    """Size of the response the margin tolerance is relative to."""
    if model.kind == "S":
        return 1.0
    return scaled_model(model)[2]


# ---------------------------------------------------------------------- classification
def _edges_from_sampling(
    model: RationalModel,
    n_samples: int,
    tol: float,
    around: FloatArray | None = None,
    near: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, float]:
    """Sign changes of the margin on a dense grid, refined by brentq (rad/s); also the
    grid and the smallest margin on it. ``around``: frequencies (rad/s) sampled closely
    on both sides (band edges of the Hamiltonian test); ``near``: frequencies (rad/s)
    whose +-1 % is sampled every 0.05 % (eigenvalues near the axis)."""
    mags = np.abs(model.poles) if model.n_poles else np.array([1.0])
    mags = mags[mags > 0] if np.any(mags > 0) else np.array([1.0])
    grid = [np.logspace(np.log10(mags.min()) - 6, np.log10(mags.max()) + 4, n_samples)]
    for p in model.poles[model.poles.imag > 0]:
        # resonances: dense points within a few bandwidths of each peak
        grid.append(p.imag + abs(p.real) * np.linspace(-8, 8, 41))
    if around is not None and around.size:
        rel = np.array([-3e-2, -1e-3, -1e-6, 1e-6, 1e-3, 3e-2])
        grid.append((around[:, None] * (1.0 + rel[None, :])).ravel())
    if near is not None and near.size:
        grid.append((near[:, None] * (1.0 + _NEAR_SPAN[None, :])).ravel())
    w = np.unique(np.concatenate(grid))
    w = w[w > 0]
    m = passivity_margin(model, w)
    m_dc = float(passivity_margin(model, [0.0])[0])
    bad = m < -tol
    flips = np.flatnonzero(bad[1:] != bad[:-1])

    def f(x: float) -> float:
        return float(passivity_margin(model, [x])[0]) + tol

    edges = []
    for i in flips:
        try:
            edges.append(brentq(f, w[i], w[i + 1], xtol=1e-14 * w[i], rtol=1e-15))
        except ValueError:  # the margin sits at the tolerance: the grid point will do
            edges.append(float(np.sqrt(w[i] * w[i + 1])))
    return np.asarray(edges, dtype=float), w, min(float(np.min(m)), m_dc)


def _classify(
    model: RationalModel, omega: FloatArray, tol: float
) -> tuple[list[tuple[float, float]], list[float]]:
    """Violation bands (rad/s) from candidate crossings, and the crossings that bound them."""
    w_ref = float(np.max(np.abs(model.poles))) if model.n_poles else 1.0
    pts = np.concatenate([[0.0], omega, [np.inf]])
    mids = np.empty(pts.size - 1)
    for i in range(mids.size):
        lo, hi = pts[i], pts[i + 1]
        if lo == 0.0:
            mids[i] = 0.5 * hi if np.isfinite(hi) else w_ref
        elif not np.isfinite(hi):
            mids[i] = 2.0 * lo
        else:
            mids[i] = np.sqrt(lo * hi)
    bad = passivity_margin(model, mids) < -tol
    bands: list[tuple[float, float]] = []
    crossings: list[float] = []
    i = 0
    while i < bad.size:
        if bad[i]:
            j = i
            while j + 1 < bad.size and bad[j + 1]:
                j += 1
            bands.append((float(pts[i]), float(pts[j + 1])))
            i = j + 1
        else:
            i += 1
    for lo, hi in bands:
        crossings += [x for x in (lo, hi) if 0 < x < np.inf]
    return bands, crossings


def _polish(model: RationalModel, w: float, tol: float) -> float:
    """Refine a crossing by bracketing the sign change of the margin (Newton-free)."""

    def f(x: float) -> float:
        return float(passivity_margin(model, [x])[0]) + tol

    for rel in (1e-9, 1e-7, 1e-5):
        lo, hi = w * (1 - rel), w * (1 + rel)
        flo, fhi = f(lo), f(hi)
        if flo * fhi < 0:
            return float(brentq(f, lo, hi, xtol=1e-15 * w, rtol=1e-15))
    return w


def _merged(bands: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Bands with ordered edges, overlapping or touching ones merged. Polishing moves
    each edge on its own: crossings within 1e-7 of each other (a 67-pole fit of a COMSOL
    microstrip export, edges 7381070048, 7381071390 and 7381070870 rad/s) can change
    order, and a band ended below its start (scipy's bounded search then raised
    "The lower bound exceeds the upper bound")."""
    out: list[tuple[float, float]] = []
    for lo, hi in sorted((min(a, b), max(a, b)) for a, b in bands):
        if out and lo <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], hi))
        else:
            out.append((lo, hi))
    return out


def _worst(
    model: RationalModel, bands: list[tuple[float, float]]
) -> tuple[float, float | None]:
    """Most negative margin over the bands (rad/s): (violation >= 0, omega)."""
    best, where = 0.0, None
    for lo, hi in bands:
        a = max(lo, 1e-6 * hi) if np.isfinite(hi) else max(lo, 1e-300)
        b = hi if np.isfinite(hi) else max(lo, 1.0) * 1e4
        if a <= 0:
            a = b * 1e-9
        x = np.logspace(np.log10(a), np.log10(b), 257)
        m = passivity_margin(model, x)
        k = int(np.argmin(m))
        ka, kb = max(k - 1, 0), min(k + 1, x.size - 1)
        res = minimize_scalar(
            lambda t: float(passivity_margin(model, [np.exp(t)])[0]),
            bounds=(np.log(x[ka]), np.log(x[kb])),
            method="bounded",
            options={"xatol": 1e-10},
        )
        cand = [(float(m[k]), float(x[k])), (float(res.fun), float(np.exp(res.x)))]
        val, w = min(cand)
        if -val > best:
            best, where = -val, w
    return best, where


# ---------------------------------------------------------------------- public API
@capped_blas
def check_passivity(
    model: RationalModel,
    *,
    method: CheckMethod = "auto",
    n_samples: int = 20000,
) -> PassivityReport:
    """Test a Z, Y or S rational model for passivity and locate its violation bands.

    Parameters
    ----------
    model : RationalModel
        Model of kind "Z", "Y" (positive-realness) or "S" (bounded-realness).
    method : {"auto", "hamiltonian", "sampling"}
        "auto": Hamiltonian eigenvalues, dense sampling if the eigenvalue solver fails (with
        a :class:`~vfmodel.errors.PassivityWarning`). "sampling": dense sampling only
        (a check, never a certificate of bands narrower than the grid).
    n_samples : int
        Log-spaced grid size of the sampling method (plus points around every resonance).

    Returns
    -------
    PassivityReport

    References
    ----------
    S. Boyd, V. Balakrishnan, P. Kabamba (1989), doi:10.1007/BF02551387;
    S. Grivet-Talocia (2004), doi:10.1109/TCSI.2004.834527.
    """
    _check_kind(model)
    if method not in ("auto", "hamiltonian", "sampling"):
        raise InputError(
            "method: unknown choice", found=repr(method), expected="auto, hamiltonian, sampling"
        )
    stable = bool(np.all(model.poles.real < 0))
    asym_ok, d_margin, e_ok = _asymptotics(model)
    tol = 1e-12 * _scale(model)
    notes: list[str] = []
    if not stable:
        notes.append("model has poles with Re(p) >= 0: not passive (refit or flip poles)")
    if not e_ok:
        notes.append(
            "E must be symmetric PSD (Z, Y) or zero (S); bands below ignore E"
        )
    used: Literal["hamiltonian", "sampling"] = "hamiltonian"
    form: str | None = None
    omega: FloatArray
    near: FloatArray = np.zeros(0)
    if method != "sampling":
        try:
            cr = crossing_frequencies(model)
            omega, form, near = cr.omega, cr.form, cr.near
        except (np.linalg.LinAlgError, ValueError) as err:
            if method == "hamiltonian":
                raise PassivityError(f"Hamiltonian eigenvalue problem failed: {err}") from err
            warnings.warn(
                f"Hamiltonian passivity test failed ({err}); fell back to dense sampling, "
                "which cannot certify passivity between samples",
                PassivityWarning,
                stacklevel=3,  # the caller's line (capped_blas adds a frame)
            )
            used = "sampling"
    else:
        used = "sampling"
    if used == "sampling":
        omega, _, min_margin = _edges_from_sampling(model, n_samples, tol)
    else:
        # cross-check of the eigenvalue test: a crossing it misses (rounding in a nearly
        # singular or badly scaled pencil) shows as a sign change on a dense grid, which
        # also samples both sides of every edge it found, 0 Hz and far beyond the poles
        edges, _, min_margin = _edges_from_sampling(model, _CROSS_CHECK, tol, around=omega,
                                                    near=near)
        missed = [x for x in edges if not np.any(np.abs(omega - x) <= 1e-6 * x)]
        if missed:
            notes.append(
                f"dense sampling found {len(missed)} band edge(s) the Hamiltonian "
                "eigenvalues missed; bands include them"
            )
            omega = np.unique(np.concatenate([omega, np.asarray(missed)]))
    bands, crossings = _classify(model, omega, tol)
    if not bands and min_margin < -tol:  # a sampled violation no interval shows
        w_dc = 0.0 if float(passivity_margin(model, [0.0])[0]) < -tol else None
        edges, _, _ = _edges_from_sampling(model, 4 * _CROSS_CHECK, tol, around=omega)
        omega = np.unique(np.concatenate([omega, edges]))
        bands, crossings = _classify(model, omega, tol)
        if not bands and w_dc is not None:
            bands = [(0.0, float(omega[0]) if omega.size else np.inf)]
        notes.append("violation found by sampling only")
    if used == "hamiltonian" and bands:
        polished = {w: _polish(model, w, tol) for w in crossings}
        bands = _merged([(polished.get(lo, lo), polished.get(hi, hi)) for lo, hi in bands])
        crossings = sorted(polished[w] for w in crossings)
    worst, where = _worst(model, bands)
    if model.kind == "S":
        asym_viol = max(0.0, -d_margin)
    else:
        asym_viol = max(0.0, -d_margin)
    if asym_viol > worst:
        worst, where = asym_viol, np.inf
    two_pi = 2 * np.pi
    passive = stable and asym_ok and not bands
    return PassivityReport(
        passive=passive,
        stable=stable,
        kind=model.kind,
        method=used,
        hamiltonian_form=form,
        bands_hz=tuple((lo / two_pi, hi / two_pi) for lo, hi in bands),
        crossings_hz=tuple(w / two_pi for w in crossings),
        worst_violation=float(worst),
        worst_freq_hz=None if where is None else float(where / two_pi),
        asymptotic_ok=asym_ok,
        d_margin=d_margin,
        e_ok=e_ok,
        notes=tuple(notes),
        min_margin=min(float(min_margin), float(d_margin)),
    )


@capped_blas
def enforce_passivity(
    model: RationalModel,
    data: FrequencyData | skrf.Network | str | os.PathLike[str] | None = None,
    *,
    weighting: Literal["auto", "relative", "uniform"] = "auto",
    perturb_d: bool = True,
    max_iter: int = ENFORCE_ITERATIONS,
    margin: float = 1e-6,
    allow_active: bool = False,
    progress: Progress = no_progress,
    keep_margin: bool = True,
    time_limit: float | None = None,
) -> tuple[RationalModel, PassivityReport]:
    """Make a stable Z, Y or S model passive with the smallest weighted change of its response.

    Residues (conjugate pairs kept conjugate) and, if ``perturb_d``, D are perturbed by a
    quadratic program (cvxpy, Clarabel): minimise the weighted change of H on the data
    frequencies subject to linear cuts ``Re(v^H H v) >= margin`` (Z, Y; v an eigenvector
    of the Hermitian part at a violating frequency) resp. ``Re(u^H H v) <= 1 - margin``
    (S; u, v a singular pair) -- the linearised eigenvalue / singular value constraints of
    Gustavsen, each an exact half space of the passive set -- plus the exact asymptotic
    condition on D. Violations are found on a dense grid and by the Hamiltonian test; new
    cuts are added and the program is solved again from the original model until the
    Hamiltonian test certifies passivity.

    Parameters
    ----------
    model : RationalModel
        Stable Z, Y or S model.
    data : FrequencyData, skrf.Network or path, optional
        Frequencies (and magnitudes, for the relative weighting) of the data the model was
        fitted to, taken as :func:`vfmodel.vector_fit` takes them; converted to the
        model's kind. Default: 400 log-spaced points over the
        model's poles, weighted by the model's own response.
    weighting : {"auto", "relative", "uniform"}
        Weight of the change of entry (i, j) at frequency f: ``1 / |H_ij(f)|`` (floored at
        1e-3 of the largest entry at that frequency) or 1. "auto": uniform for S models
        (the norm of their fit and of its relative RMS error over all entries), relative for
        Z and Y models (their fits are judged per point).
    perturb_d : bool
        Also perturb D (the asymptotic conditions become constraints).
    max_iter : int
        Convex programs to solve at most before giving up.
    margin : float
        Required margin at the cut frequencies, relative: ``min eig(Re H) >=
        margin * ||H||`` (Z, Y) or ``sigma_max(H) <= 1 - margin`` (S); in (0, 0.1).
    keep_margin : bool
        The programs' change is then moved back towards the fit as far as the Hamiltonian
        certificate allows (bisection on the segment, the point of least error on the
        data kept). True (default): not below the margin at the cut frequencies; False:
        the margin only helps the programs and may be given back (a change resolved
        finer than the programs' 1e-10, e.g. for nearly lossless fits).
    allow_active : bool
        Enforce even when the data are active (their passivity violation floor,
        :func:`vfmodel.fitting.data_passivity.data_passivity`, exceeds 5 %); by default
        that is refused, since a passive model of an amplifier is not a model of it.
    progress : callable
        ``progress(stage, done, total)`` once per convex program (programs of a many-pole
        model can take seconds to a minute each).
    time_limit : float, optional
        Seconds after which the running convex program stops and no further one starts
        (the first always runs to its end); a model not certified by then raises
        :class:`PassivityError`. None: no limit.

    Returns
    -------
    (RationalModel, PassivityReport)
        The passive model and its certified Hamiltonian check (with ``iterations`` and the
        RMS change).

    Raises
    ------
    InputError
        Active data (unless ``allow_active``), data of another port count.
    PassivityError
        Unstable model, E that cannot be made passive, or no certificate after
        ``max_iter`` programs or within ``time_limit``.
    SolverError
        A convex program did not end with status "optimal".

    References
    ----------
    B. Gustavsen, A. Semlyen (2001), doi:10.1109/59.910778;
    B. Gustavsen (2008), doi:10.1109/TPWRD.2007.915883;
    S. Grivet-Talocia, B. Gustavsen (2016), doi:10.1002/9781119140931.
    """
    from vfmodel.fitting._enforce import enforce
    from vfmodel.fitting.data_passivity import ACTIVE_FLOOR, data_passivity

    _check_kind(model)
    if data is not None:
        data = as_frequency_data(data, source="enforce_passivity")
        if data.kind == "H":
            raise InputError("passivity data must be Z, Y or S", source=data.source)
        if data.kind != model.kind or (model.kind == "S" and data.z0 != model.z0):
            data = data.to_kind(model.kind, model.z0)
        dp = data_passivity(data)
        if dp is not None and dp.active and not allow_active:
            raise InputError(
                "the data are active: no passive model can come closer to them than "
                f"{100 * dp.floor:.3g} % (largest violation {dp.worst_violation:.3g} at "
                f"{dp.worst_freq_hz:.6g} Hz); passivity enforcement refused",
                source=data.source,
                expected=f"data within {100 * ACTIVE_FLOOR:g} % of passive, or "
                "allow_active=True",
            )
    if time_limit is not None and not time_limit >= 0:  # NaN too
        raise InputError("time_limit must be a number of seconds >= 0",
                         found=repr(time_limit), expected="seconds >= 0, or None")
    deadline = None if time_limit is None else time.monotonic() + time_limit
    if weighting == "auto":
        weighting = "uniform" if model.kind == "S" else "relative"
    if model.delay:
        # |exp(-j w delay)| = 1: enforce on the rational part against the advanced data
        if data is not None:
            data = data.with_values(
                data.values * np.exp(2j * np.pi * data.freq_hz * model.delay)[:, None, None]
            )
        rational, report = enforce(
            model.without_delay(), data, weighting=weighting, perturb_d=perturb_d,
            max_iter=max_iter, margin=margin, keep_margin=keep_margin, progress=progress,
            deadline=deadline,
        )
        return RationalModel(rational.poles, rational.residues, rational.d, rational.e,
                             rational.kind, rational.z0, delay=model.delay), report
    return enforce(
        model,
        data,
        weighting=weighting,
        perturb_d=perturb_d,
        max_iter=max_iter,
        margin=margin,
        keep_margin=keep_margin,
        progress=progress,
        deadline=deadline,
    )
