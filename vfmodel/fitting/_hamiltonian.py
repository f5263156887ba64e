"""Hamiltonian (para-Hermitian zero) kernels of the passivity test.

A passivity violation band of a stable rational model starts and ends where the Popov
function Phi(j w) becomes singular:

- immittance (Z, Y): Phi(s) = H(s) + H(-s)^T, singular where an eigenvalue of the Hermitian
  part of H(j w) crosses zero;
- scattering (S): Phi(s) = [[I, H(s)], [H(-s)^T, I]], det Phi = det(I - H^H H) on the j w axis,
  singular where a singular value of H(j w) crosses one.

Phi has the real realisation (A_p, B_p, C_p, D_p) built below; its finite zeros are the
generalized eigenvalues of the pencil ``[[A_p, B_p], [C_p, D_p]] - s [[I, 0], [0, 0]]``.
With D_p non-singular they are the eigenvalues of the Hamiltonian matrix
``M = A_p - B_p D_p^-1 C_p`` (for immittance with Q = D + D^T this is the classical
``[[A - B Q^-1 C, -B Q^-1 B^T], [C^T Q^-1 C, -A^T + C^T Q^-1 B^T]]``). When D_p is singular
(e.g. a 1-port impedance fitted with D = 0, or an S model with a unit singular value of D)
the pencil form is used instead, so no regularisation is needed.

References
----------
.. [1] S. Boyd, V. Balakrishnan, P. Kabamba, "A bisection method for computing the H-infinity
   norm of a transfer matrix and related problems", Math. Control Signals Systems 2 (1989),
   doi:10.1007/BF02551387.
.. [2] S. Grivet-Talocia, "Passivity enforcement via perturbation of Hamiltonian matrices",
   IEEE Trans. Circuits Syst. I 51(9) (2004), doi:10.1109/TCSI.2004.834527.
.. [3] S. Grivet-Talocia, B. Gustavsen, "Passive Macromodeling: Theory and Applications",
   Wiley (2016), ch. 9 (extended Hamiltonian pencils), doi:10.1002/9781119140931.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import scipy.linalg as sla
from numpy.typing import NDArray

from vfmodel.core.rational_model import RationalModel

FloatArray = NDArray[np.float64]

HamiltonianForm = Literal["standard", "pencil"]

# relative size of |Re(lambda)| below which an eigenvalue counts as purely imaginary; a
# spurious candidate only splits an interval that the classification step merges again
_IMAG_TOL = 1e-4
# ... and below which it is a place the sampling cross-check looks at closely
# (``Crossings.near``): the eigenvalues of a badly scaled Hamiltonian can be off the axis by
# far more than _IMAG_TOL. scikit-rf's wr1p5,line.s2p enforced (19 poles, residues up to
# 300x the response, ||M|| = 8e5): a band 837.1-839.9 GHz where sigma = 1 + 1.1e-10 had
# eigenvalues at Re/Im = 1.2e-4 and 8.8e-4 on either side of it, and the 3000-point
# cross-check (0.8 % apart there) missed it: a false certificate
_NEAR_TOL = 1e-2
# D_p is treated as singular when its smallest singular value is below this, relative to
# max(1, sigma_max(D_p)) (the scaled response is O(1)); the standard form loses accuracy
# as 1/sigma_min(D_p) and missed narrow bands of nearly singular D + D^T at 1e-9
_RCOND_SINGULAR = 1e-5


@dataclass(frozen=True)
class Crossings:
    """Candidate crossing frequencies (rad/s, ascending, > 0) and the form used; ``near``:
    the imaginary parts (rad/s) of further eigenvalues near the axis (``_NEAR_TOL``)."""

    omega: FloatArray
    form: HamiltonianForm
    near: FloatArray = field(default_factory=lambda: np.zeros(0))


def scaled_model(model: RationalModel) -> tuple[RationalModel, float, float]:
    """Return ``(H', w0, h0)`` with ``H'(s') = H(w0 s') / h0`` (E dropped).

    Scaling the frequency by the largest pole magnitude and (for Z, Y only) the response by
    its typical size makes the Hamiltonian entries O(1), which keeps the eigenvalues accurate
    for poles that span decades. E is dropped: its passivity condition (symmetric PSD for
    Z, Y; zero for S) is checked separately, and a symmetric E adds nothing to Re H(j w).
    """
    w0 = float(np.max(np.abs(model.poles))) if model.n_poles else 1.0
    w0 = w0 if w0 > 0 else 1.0
    h0 = 1.0
    if model.kind in ("Z", "Y"):
        w = w0 * np.logspace(-4, 1, 61)
        h = np.abs(model.evaluate_s(1j * w) - 1j * w[:, None, None] * model.ee[None])
        h0 = float(np.max(h)) if np.max(h) > 0 else 1.0
    scaled = RationalModel(
        poles=model.poles / w0,
        residues=model.residues / (w0 * h0),
        d=model.dd / h0,
        e=None,
        kind=model.kind,
        z0=model.z0,
    )
    return scaled, w0, h0


def popov_realisation(
    model: RationalModel,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Real realisation (A_p, B_p, C_p, D_p) of the Popov function Phi(s) of ``model``."""
    ss = model.to_state_space()
    a, b, c, d = ss.a, ss.b, ss.c, ss.d
    n = model.n_in
    nx = a.shape[0]
    z = np.zeros((nx, nx))
    a_p = np.block([[a, z], [z, -a.T]])
    if model.kind == "S":
        # Phi = [[I, H(s)], [H(-s)^T, I]]; H(-s)^T = B^T (sI + A^T)^-1 (-C^T) + D^T
        zb = np.zeros((nx, n))
        b_p = np.block([[zb, b], [-c.T, zb]])
        c_p = np.block([[c, zb.T], [zb.T, b.T]])
        d_p = np.block([[np.eye(n), d], [d.T, np.eye(n)]])
    else:
        # Phi = H(s) + H(-s)^T
        b_p = np.vstack([b, -c.T])
        c_p = np.hstack([c, b.T])
        d_p = d + d.T
    return a_p, b_p, c_p, d_p


def crossing_frequencies(model: RationalModel) -> Crossings:
    """Frequencies (rad/s of ``model``) where Phi(j w) is singular: the violation band edges.

    Parameters
    ----------
    model : RationalModel
        Stable Z, Y or S model (the caller checks stability and kind).

    Returns
    -------
    Crossings
        Ascending positive candidate frequencies; every true crossing is among them (up to
        the eigenvalue accuracy), spurious candidates are removed by the caller's
        classification of the intervals between them.

    Raises
    ------
    numpy.linalg.LinAlgError
        When the eigenvalue solver fails (the caller falls back to sampling).
    """
    scaled, w0, _ = scaled_model(model)
    if scaled.n_poles == 0:
        return Crossings(np.zeros(0), "standard")
    a_p, b_p, c_p, d_p = popov_realisation(scaled)
    sv = np.linalg.svd(d_p, compute_uv=False)
    form: HamiltonianForm
    if sv[-1] > _RCOND_SINGULAR * max(1.0, float(sv[0])):
        form = "standard"
        m = a_p - b_p @ np.linalg.solve(d_p, c_p)
        lam = np.linalg.eigvals(m)
    else:
        form = "pencil"
        nx = a_p.shape[0]
        big = np.block([[a_p, b_p], [c_p, d_p]])
        e_p = np.zeros_like(big)
        e_p[:nx, :nx] = np.eye(nx)
        alpha, beta = sla.eigvals(big, e_p, homogeneous_eigvals=True)
        finite = np.abs(beta) > 1e-12 * np.abs(alpha)
        lam = alpha[finite] / beta[finite]
        # drop eigenvalues far beyond the model's bandwidth (infinite ones perturbed by
        # rounding); the interval above the last crossing is classified separately
        lam = lam[np.abs(lam) < 1e6]
    lam = lam[np.isfinite(lam)]
    imag = np.abs(lam.imag)
    on_axis = (np.abs(lam.real) <= _IMAG_TOL * np.maximum(imag, 1e-3)) & (lam.imag > 1e-9)
    omega = np.sort(imag[on_axis]) * w0
    if omega.size > 1:  # merge duplicates (a crossing found twice)
        keep = np.concatenate([[True], np.diff(omega) > 1e-12 * omega[1:]])
        omega = omega[keep]
    close = ~on_axis & (np.abs(lam.real) <= _NEAR_TOL * imag) & (lam.imag > 1e-9)
    return Crossings(omega, form, np.sort(imag[close]) * w0)
