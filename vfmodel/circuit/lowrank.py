"""Transfers of a network in which only a few elements change: a low-rank update.

When a fit moves only some elements (the lubricant film of one speed while the machine
stays as identified), the network matrix is ``A(s) = A0(s) + E D(s) E^T`` with ``A0`` the
network at reference values ``v0``, ``E`` the unit columns of the ``r`` rows and columns
the moving elements stamp into, and ``D(s)`` (r x r) the stamps of the changes
``q(v) - q(v0)`` of their stamp quantities. With the reference network's transfers

    h0 = Cout^T A0^-1 B,   u = Cout^T A0^-1 E,   w = E^T A0^-1 B,   M = E^T A0^-1 E,

computed once on the frequencies, the Woodbury identity gives

    H = h0 - u (I + D M)^-1 D w,
    dH / dq_p = - u (I + D M)^-1 (dD / dq_p) (I + M D)^-1 w,

an r x r solve per frequency instead of a factorisation of the whole network (W. W.
Hager, "Updating the inverse of a matrix", SIAM Review 31(2), 221-239, 1989,
doi:10.1137/1031049). The derivatives come exactly on every frequency (no interpolation
grid). The reference transfers come from direct sparse solves with the extra right-hand
sides (one factorisation per frequency, once per fit).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vfmodel.circuit.mna import _Q_INV, MnaSystem

__all__ = ["LowRankTransfer", "low_rank_transfer"]

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]
ArrI = NDArray[np.intp]


@dataclass(frozen=True)
class LowRankTransfer:
    """``Cout^T (G + sC)^-1 B`` on fixed frequencies for element values that differ from
    ``v0`` only in the elements ``moving`` (see the module docstring)."""

    v0: ArrF                 # reference element values
    moving: ArrI             # indices of the elements that may change
    q0: ArrF                 # their stamp quantities at v0
    q_inv: NDArray[np.bool_]  # per moving element: stamp quantity 1/v (else v)
    freq_hz: ArrF            # (n_f,)
    s: ArrC                  # (n_f,) 2 pi j f
    t_param: ArrI            # per triplet of a moving element: its position in ``moving``
    t_row: ArrI              # ... its row and column among the r touched indices
    t_col: ArrI
    t_coef: ArrF
    t_is_c: NDArray[np.bool_]
    h0: ArrC                 # (n_f, n_out, n_in)
    u: ArrC                  # (n_f, n_out, r)
    w: ArrC                  # (n_f, r, n_in)
    m: ArrC                  # (n_f, r, r)

    @property
    def _wg(self) -> ArrF:
        """(n_triplets, n_moving): coefficient of each G triplet at its element."""
        out = np.zeros((self.t_coef.size, self.moving.size))
        out[np.arange(self.t_coef.size), self.t_param] = np.where(self.t_is_c, 0.0, self.t_coef)
        return out

    @property
    def _wc(self) -> ArrF:
        """(n_triplets, n_moving): coefficient of each C triplet at its element."""
        out = np.zeros((self.t_coef.size, self.moving.size))
        out[np.arange(self.t_coef.size), self.t_param] = np.where(self.t_is_c, self.t_coef, 0.0)
        return out

    def applies(self, v: ArrF, freq_hz: ArrF | None = None) -> bool:
        """True when ``v`` differs from the reference only in the moving elements (and
        ``freq_hz``, when given, are the form's frequencies)."""
        if freq_hz is not None and not (freq_hz is self.freq_hz or np.array_equal(
                np.asarray(freq_hz, dtype=float), self.freq_hz)):
            return False
        if np.shape(v) != self.v0.shape:         # another network
            return False
        fixed = np.ones(self.v0.size, dtype=bool)
        fixed[self.moving] = False
        return bool(np.array_equal(v[fixed], self.v0[fixed]))

    def _change(self, v: ArrF) -> tuple[ArrF, ArrF, ArrF]:
        """``D(s) = dg + s dc`` of ``v`` as the two constant (r, r) parts, and ``dq/dv``
        of the moving elements."""
        vm = np.asarray(v, dtype=float)[self.moving]
        q = np.where(self.q_inv, 1.0 / vm, vm)
        dqdv = np.where(self.q_inv, -1.0 / vm ** 2, 1.0)
        r = self.m.shape[1]
        wt = self.t_coef * (q - self.q0)[self.t_param]
        g = np.zeros((r, r))
        c = np.zeros((r, r))
        ic = self.t_is_c
        np.add.at(g, (self.t_row[~ic], self.t_col[~ic]), wt[~ic])
        np.add.at(c, (self.t_row[ic], self.t_col[ic]), wt[ic])
        return g, c, dqdv

    def _solve(self, v: ArrF, k: ArrI | slice) -> tuple[ArrC, ArrC, ArrF]:
        """On the frequencies ``k``: ``I + D M`` and ``D w``; ``dq/dv``."""
        g, c, dqdv = self._change(v)
        s = self.s[k][:, None, None]
        m, w = self.m[k], self.w[k]
        # D M and D w from the constant parts (broadcast products: 6x faster than einsum),
        # in place where possible: this is most of a lubricant fit's time
        a = g @ m
        cm = c @ m
        cm *= s
        a += cm
        a += np.eye(m.shape[1])
        dw = g @ w
        cw = c @ w
        cw *= s
        dw += cw
        return a, dw, dqdv

    def __call__(self, v: ArrF) -> ArrC:
        """Transfer (n_f, n_out, n_in) at element values ``v``."""
        a, dw, _ = self._solve(v, slice(None))
        return np.asarray(self.h0 - self.u @ np.linalg.solve(a, dw), dtype=complex)

    def with_derivatives(self, v: ArrF, k: ArrI | slice = slice(None)) -> tuple[ArrC, ArrC]:
        """Transfer and ``d H / d v`` of the moving elements on the frequencies ``k`` (all by
        default): (n_k, n_out, n_in) and (n_k, n_out, n_in, n_moving)."""
        a, dw, dqdv = self._solve(v, k)
        inv = np.linalg.inv(a)
        u, w, m = self.u[k], self.w[k], self.m[k]
        alpha_t = u @ inv                              # u (I + D M)^-1          (f, o, r)
        x = inv @ dw
        h = self.h0[k] - u @ x
        beta = w - m @ x                               # (I + M D)^-1 w (push-through)
        # per triplet: -coef (s or 1) alpha[row] beta[col], summed per moving element
        ag = alpha_t[:, :, self.t_row]                                   # (f, o, t)
        bg = np.swapaxes(beta, 1, 2)[:, :, self.t_col]                   # (f, i, t)
        prod = (ag[:, :, None, :] * bg[:, None, :, :]).reshape(-1, self.t_coef.size)
        sk = np.repeat(self.s[k], prod.shape[0] // max(len(self.s[k]), 1))
        jac = -(prod @ self._wg + sk[:, None] * (prod @ self._wc))
        return (np.asarray(h, dtype=complex),
                jac.reshape(*h.shape, self.moving.size) * dqdv)


def low_rank_transfer(mna: MnaSystem, b: ArrF, cout: ArrF, v0: ArrF, freq_hz: ArrF,
                      moving: ArrI, *, direct: bool = True) -> LowRankTransfer | None:
    """The low-rank form for the elements ``moving`` (None when there are none or one is
    part of a mutual coupling, whose stamp is not linear in one value).

    ``direct``: the reference transfers from sparse solves (exact); else from the
    pole-residue form of :func:`vfmodel.circuit.transfer.transfer_on`, whose check is
    relative to the largest of the stacked responses (here the impedances ``M`` of the
    touched nodes), so that the small transfers ``h0``, ``w`` can be off by far more than
    its tolerance; the update amplifies that error where ``D^-1 + M`` is nearly singular
    (measured on a PMSM network: 2.8 % of the bearing transfer after a contact
    resistance moved 0.001 -> 53 ohm, against 3e-8 with exact references)."""
    moving = np.unique(np.asarray(moving, dtype=np.intp))
    mut = set(mna.mut_params.tolist()) | set(mna.mut_l1.tolist()) | set(mna.mut_l2.tolist())
    if moving.size == 0 or mut & set(moving.tolist()):
        return None
    v0 = np.array(v0, dtype=float)
    pos = np.full(len(mna.param_names), -1, dtype=np.intp)
    pos[moving] = np.arange(moving.size)
    tsel = np.flatnonzero(pos[mna.t_param] >= 0)
    touched = np.unique(np.concatenate([mna.t_row[tsel], mna.t_col[tsel]]))
    where = np.full(mna.size, -1, dtype=np.intp)
    where[touched] = np.arange(touched.size)
    e = np.zeros((mna.size, touched.size))
    e[touched, np.arange(touched.size)] = 1.0
    n_o, n_i = cout.shape[1], b.shape[1]
    f = np.asarray(freq_hz, dtype=float)
    bb, cc = np.hstack([b, e]), np.hstack([cout, e])
    if direct:
        t = mna.solve(f, bb, cc, v0, method="sparse").h
    else:
        from vfmodel.circuit.transfer import transfer_on

        t = transfer_on(mna, bb, cc, v0, f)
    q0, _ = mna._q(v0)
    return LowRankTransfer(
        v0, moving, q0[moving], mna.q_type[moving] == _Q_INV, f, 2j * np.pi * f,
        pos[mna.t_param[tsel]], where[mna.t_row[tsel]], where[mna.t_col[tsel]],
        np.asarray(mna.t_coef[tsel], dtype=float), np.asarray(mna.t_is_c[tsel], dtype=bool),
        t[:, :n_o, :n_i], t[:, :n_o, n_i:], t[:, n_o:, :n_i], t[:, n_o:, n_i:])
