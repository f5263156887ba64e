"""Network poles (natural frequencies) from the generalized eigenproblem of (G, C).

The natural frequencies of the MNA system ``(G + s C) x = 0`` with every independent
source set to zero (voltage sources shorted, current sources open, switches in their
state) are the finite generalized eigenvalues ``s`` of ``-G v = s C v``. Rows without
dynamics (resistive nodes, source and switch rows) give infinite eigenvalues, which are
discarded. The pencil is solved by the QZ algorithm, which is backward stable, so poles
spread over many decades keep their relative accuracy.

References
----------
C. B. Moler, G. W. Stewart, "An algorithm for generalized matrix eigenvalue problems",
SIAM J. Numer. Anal. 10(2), 241-256, 1973. doi:10.1137/0710024
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike, NDArray

from vfmodel.circuit._solvers import INF_RATIO_POLES, balance_pencil, finite_mask
from vfmodel.circuit.mna import MnaSystem
from vfmodel.circuit.netlist import Circuit
from vfmodel.errors import CircuitError


def network_poles(
    circuit: Circuit | MnaSystem,
    values: Mapping[str, float] | ArrayLike | None = None,
) -> NDArray[np.complex128]:
    """Finite natural frequencies (rad/s) of a circuit, sorted by magnitude.

    Parameters
    ----------
    circuit : Circuit or MnaSystem
    values : mapping or vector, optional
        Parameter values (default: those of the circuit).

    Returns
    -------
    (n_poles,) complex
        Poles, conjugate pairs adjacent (positive imaginary part first), sorted by
        ``|s|``; real poles have an exactly zero imaginary part.

    Raises
    ------
    CircuitError
        When the pencil is singular (det(G + sC) = 0 for every s).
    """
    mna = circuit.mna if isinstance(circuit, Circuit) else circuit
    g, c = mna.matrices(values)
    # balance the pencil with diagonal scaling so that the rows and columns of different
    # physical units (A, V, S, H) have comparable norms; eigenvalues are unchanged
    gs, cs, _, _ = balance_pencil(g, c)
    w = sla.eig(-gs, cs, right=False, homogeneous_eigvals=True)
    alpha, beta = w[0], w[1]
    if np.any((np.abs(alpha) < 1e-14) & (np.abs(beta) < 1e-14)):
        raise CircuitError("network_poles: the pencil (G, C) is singular (det(G + sC) = 0 "
                           "for all s); the network has no unique solution")
    finite = finite_mask(alpha, beta, gs, cs, INF_RATIO_POLES)
    p = alpha[finite] / beta[finite]
    return _pair_and_sort(p)


def _pair_and_sort(p: NDArray[np.complex128]) -> NDArray[np.complex128]:
    mag = np.abs(p)
    real = np.abs(p.imag) <= 1e-10 * np.maximum(mag, 1e-300)
    out = [complex(x.real, 0.0) for x in p[real]]
    upper = p[~real & (p.imag > 0)]
    out_pairs = [complex(x) for x in upper]
    items: list[tuple[float, list[complex]]] = [(abs(x), [x]) for x in out]
    for x in out_pairs:
        items.append((abs(x), [x, x.conjugate()]))
    items.sort(key=lambda t: t[0])
    flat = [z for _, zs in items for z in zs]
    return np.asarray(flat, dtype=complex)
