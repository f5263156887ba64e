"""Modified nodal analysis in the frequency domain, batched over frequency.

The circuit equations are ``(G + s C) x = B u``, ``y = Cout^T x`` with the unknowns ``x`` =
non-ground node voltages followed by branch currents (voltage sources, inductors,
switches, VCVS, CCVS). ``G`` and ``C`` are assembled from a pattern compiled once:
every parameter-dependent entry is a triplet ``(row, col, coef, param)`` whose value is
``coef * q(param)`` with ``q = 1/R`` for resistors, ``q = M = k sqrt(L1 L2)`` for mutual
couplings and ``q = value`` otherwise, so :meth:`MnaSystem.matrices` is two ``bincount``
calls, without a Python loop over elements.

Stamps (branch current ``i_b`` flows from n+ through the element to n-):

- admittance y between a, b: ``G[a,a] += y, G[b,b] += y, G[a,b] -= y, G[b,a] -= y``;
- inductor: KCL ``+i_b`` at a, ``-i_b`` at b; row ``v_a - v_b - s L i_b = 0``; mutual
  ``- s M i_b2`` in row b1 and vice versa (SPICE dot convention: first nodes);
- voltage source / closed switch: row ``v_a - v_b = u`` (0 for the switch); an open switch
  has the row ``i_b = 0``, so the switch state does not change the matrix structure;
- VCVS row ``v_a - v_b - mu (v_c - v_d) = 0``; CCVS row ``v_a - v_b - r i_ctrl = 0``;
  VCCS ``gm (v_c - v_d)`` and CCCS ``beta i_ctrl`` leave node a and enter node b.

Sensitivities use the adjoint method: with ``x = A^-1 B`` and ``lambda = A^-T Cout``,
``dH/dp = -lambda^T (dG/dp + s dC/dp) x`` for all frequencies at once.

Solvers (``method``): ``dense`` (batched LAPACK, N <= 40) and ``sparse`` (SuperLU per
frequency) are direct and exact to rounding; ``auto`` picks one of them by size.
``hessenberg`` (module ``_hessenberg``) reduces the shifted pencil once to Hessenberg form
and then costs O(N^2) per frequency. The ``modal`` solver factorises once per parameter
set: with a real shift ``s0`` and
``K = (G + s0 C)^-1``, ``T = K C = V diag(theta) V^-1`` gives
``(G + s C)^-1 = V diag(1 / (1 + (s - s0) theta)) V^-1 K``, so each further frequency
costs O(N n_in) (fastest; use it for many evaluations with few outputs). Both fast solvers
are checked against direct solves at the band edges and the middle (norm-wise relative
agreement 1e-9 over the outputs at each checked frequency; the solvers and this tolerance
policy live in :mod:`._solvers`) and replaced by the direct solver when they fail; their
accuracy is norm-wise, so an output far smaller than the
others at the same frequency (or a derivative that is exactly zero) may carry a larger
relative error than with the direct solvers.

References
----------
C.-W. Ho, A. E. Ruehli, P. A. Brennan, "The modified nodal approach to network analysis",
IEEE Trans. Circuits Syst. 22(6), 504-509, 1975. doi:10.1109/TCS.1975.1084079
S. W. Director, R. A. Rohrer, "The generalized adjoint network and network sensitivities",
IEEE Trans. Circuit Theory 16(3), 318-323, 1969. doi:10.1109/TCT.1969.1082965
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vfmodel.circuit._solvers import (
    Solution,
    solve_dense,
    solve_hessenberg,
    solve_modal,
    solve_sparse,
)
from vfmodel.circuit.netlist import Circuit, Excitation, Probe
from vfmodel.errors import CircuitError, InputError

SolveMethod = Literal["auto", "dense", "sparse", "hessenberg", "modal"]
_DENSE_MAX = 40           # unknowns up to which "auto" uses the dense batched solver (see solve)
_CHUNK_BYTES = 64 << 20   # memory for one batch of adjoint products

_BRANCH_KINDS = ("inductor", "vsource", "switch", "vcvs", "ccvs")
_Q_LIN, _Q_INV, _Q_MUT = 0, 1, 2

ArrF = NDArray[np.float64]
ArrC = NDArray[np.complex128]
ArrI = NDArray[np.intp]


@dataclass(frozen=True)
class MnaSystem:
    """Compiled MNA pattern of a :class:`Circuit` (build with :meth:`from_circuit`).

    Attributes
    ----------
    circuit : Circuit
    size : int
        Number of unknowns N.
    node_index, branch_index : dict
        Unknown index of each non-ground node and of each element with a branch current.
    param_names : tuple of str
        Parameters in the order of value vectors.
    """

    circuit: Circuit
    size: int
    node_index: Mapping[str, int]
    branch_index: Mapping[str, int]
    param_names: tuple[str, ...]
    values0: ArrF
    fixed_g: tuple[ArrI, ArrF]           # flat index, value (constant entries of G)
    t_flat: ArrI                         # flat index row*N+col of each triplet
    t_row: ArrI
    t_col: ArrI
    t_coef: ArrF
    t_is_c: NDArray[np.bool_]
    t_param: ArrI                        # sorted ascending
    q_type: NDArray[np.int8]             # per parameter: lin / inv / mutual
    mut_params: ArrI                     # mutual parameter index, its L1 and L2 indices
    mut_l1: ArrI
    mut_l2: ArrI
    ac_input: ArrF                       # B u for ac(): every source at its AC value

    # ------------------------------------------------------------------ compile
    @classmethod
    def from_circuit(cls, circuit: Circuit) -> MnaSystem:
        """Check the topology and compile the stamp pattern (done once per structure)."""
        circuit.check()
        gnd = circuit.ground
        node_index = {n: i for i, n in enumerate(circuit.nodes)}
        nn = len(node_index)
        branch_index: dict[str, int] = {}
        for el in circuit.elements:
            if el.kind in _BRANCH_KINDS:
                branch_index[el.name] = nn + len(branch_index)
        size = nn + len(branch_index)
        pidx = {name: i for i, name in enumerate(circuit.param_names)}

        def ni(n: str) -> int:
            return -1 if n == gnd else node_index[n]

        rows: list[int] = []
        cols: list[int] = []
        coefs: list[float] = []
        is_c: list[bool] = []
        tpar: list[int] = []
        fr: list[int] = []
        fc: list[int] = []
        fv: list[float] = []
        q_type = np.zeros(len(pidx), np.int8)
        mut: list[tuple[int, int, int]] = []
        b_ac = np.zeros(size)

        def trip(r: int, c: int, coef: float, p: int, cap: bool = False) -> None:
            if r >= 0 and c >= 0:
                rows.append(r)
                cols.append(c)
                coefs.append(coef)
                is_c.append(cap)
                tpar.append(p)

        def fixed(r: int, c: int, v: float) -> None:
            if r >= 0 and c >= 0:
                fr.append(r)
                fc.append(c)
                fv.append(v)

        def admittance(a: int, b: int, p: int, cap: bool) -> None:
            trip(a, a, 1.0, p, cap)
            trip(b, b, 1.0, p, cap)
            trip(a, b, -1.0, p, cap)
            trip(b, a, -1.0, p, cap)

        def incidence(a: int, b: int, br: int) -> None:
            # KCL: branch current leaves a, enters b; branch row: v_a - v_b
            fixed(a, br, 1.0)
            fixed(b, br, -1.0)
            fixed(br, a, 1.0)
            fixed(br, b, -1.0)

        for el in circuit.elements:
            p = pidx.get(el.name, -1)
            a = ni(el.nodes[0]) if el.nodes else -1
            b = ni(el.nodes[1]) if el.nodes else -1
            k = el.kind
            if k == "resistor":
                q_type[p] = _Q_INV
                admittance(a, b, p, False)
            elif k == "conductance":
                admittance(a, b, p, False)
            elif k == "capacitor":
                admittance(a, b, p, True)
            elif k == "inductor":
                br = branch_index[el.name]
                incidence(a, b, br)
                trip(br, br, -1.0, p, True)
            elif k == "mutual":
                q_type[p] = _Q_MUT
                b1, b2 = (branch_index[r] for r in el.refs)
                trip(b1, b2, -1.0, p, True)
                trip(b2, b1, -1.0, p, True)
                mut.append((p, pidx[el.refs[0]], pidx[el.refs[1]]))
            elif k == "switch":
                br = branch_index[el.name]
                if el.closed:
                    incidence(a, b, br)
                else:
                    fixed(a, br, 1.0)
                    fixed(b, br, -1.0)
                    fixed(br, br, 1.0)
            elif k == "vsource":
                br = branch_index[el.name]
                incidence(a, b, br)
                b_ac[br] += el.value
            elif k == "isource":
                if a >= 0:
                    b_ac[a] -= el.value
                if b >= 0:
                    b_ac[b] += el.value
            elif k in ("vcvs", "vccs"):
                c, d = ni(el.nodes[2]), ni(el.nodes[3])
                if k == "vcvs":
                    br = branch_index[el.name]
                    incidence(a, b, br)
                    trip(br, c, -1.0, p)
                    trip(br, d, 1.0, p)
                else:
                    trip(a, c, 1.0, p)
                    trip(a, d, -1.0, p)
                    trip(b, c, -1.0, p)
                    trip(b, d, 1.0, p)
            elif k == "cccs":
                bc = branch_index[el.refs[0]]
                trip(a, bc, 1.0, p)
                trip(b, bc, -1.0, p)
            elif k == "ccvs":
                br = branch_index[el.name]
                incidence(a, b, br)
                trip(br, branch_index[el.refs[0]], -1.0, p)
        order = np.argsort(np.asarray(tpar, dtype=np.intp), kind="stable")
        t_row = np.asarray(rows, dtype=np.intp)[order]
        t_col = np.asarray(cols, dtype=np.intp)[order]
        mut_a = np.asarray(mut, dtype=np.intp).reshape(-1, 3)
        return cls(
            circuit=circuit,
            size=size,
            node_index=node_index,
            branch_index=branch_index,
            param_names=circuit.param_names,
            values0=circuit.param_values,
            fixed_g=(np.asarray(fr, dtype=np.intp) * size + np.asarray(fc, dtype=np.intp),
                     np.asarray(fv, dtype=float)),
            t_flat=t_row * size + t_col,
            t_row=t_row,
            t_col=t_col,
            t_coef=np.asarray(coefs, dtype=float)[order],
            t_is_c=np.asarray(is_c, dtype=bool)[order],
            t_param=np.asarray(tpar, dtype=np.intp)[order],
            q_type=q_type,
            mut_params=mut_a[:, 0].copy(),
            mut_l1=mut_a[:, 1].copy(),
            mut_l2=mut_a[:, 2].copy(),
            ac_input=b_ac,
        )

    # ------------------------------------------------------------------ parameters
    def values(self, values: Mapping[str, float] | ArrayLike | None = None) -> ArrF:
        """Full parameter vector from ``None`` (circuit values), a mapping or a vector.

        A complex vector is kept complex (complex-step differentiation: the stamps are
        analytic in the values); otherwise the result is real.
        """
        if values is None:
            return self.values0
        if isinstance(values, Mapping):
            v = self.values0.copy()
            index = {n: i for i, n in enumerate(self.param_names)}
            for k, x in values.items():
                if k not in index:
                    raise CircuitError(f"{k!r} is not a parameter of the circuit")
                v[index[k]] = float(x)
            return v
        v = np.asarray(values)
        v = v.astype(complex if np.iscomplexobj(v) else float).ravel()
        if v.size != len(self.param_names):
            raise CircuitError(f"{v.size} parameter values given, expected "
                               f"{len(self.param_names)} (see param_names)")
        return v

    def _check_values(self, v_in: ArrF) -> None:
        bad = ~np.isfinite(v_in)
        v = v_in.real
        kinds = self.q_type
        bad |= (kinds == _Q_INV) & (v == 0)
        if not self.circuit.allow_negative:
            el_kinds = [self.circuit.element(n).kind for n in self.param_names] \
                if np.any(v <= 0) else []
            for i, kd in enumerate(el_kinds):
                if kd in ("resistor", "inductor", "capacitor") and v[i] <= 0:
                    bad[i] = True
                if kd == "conductance" and v[i] < 0:
                    bad[i] = True
        if self.mut_params.size:
            km = v[self.mut_params]
            bad[self.mut_params] |= ~((np.abs(km) > 0) & (np.abs(km) <= 1))
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            name = self.param_names[i]
            raise CircuitError(f"element {name!r} ({self.circuit.element(name).kind}): "
                               f"value {v[i]!r} is not allowed")

    def _q(self, v: ArrF) -> tuple[ArrF, ArrF]:
        """Stamp quantities q(v) and their diagonal derivative dq/dv."""
        q = v.copy()
        dq = np.ones_like(v)
        inv = self.q_type == _Q_INV
        q[inv] = 1.0 / v[inv]
        dq[inv] = -1.0 / v[inv] ** 2
        if self.mut_params.size:
            ll = v[self.mut_l1] * v[self.mut_l2]
            root = np.sqrt(ll) if np.iscomplexobj(ll) else np.sqrt(np.abs(ll))
            q[self.mut_params] = v[self.mut_params] * root
            dq[self.mut_params] = root
        return q, dq

    def matrices(self, values: Mapping[str, float] | ArrayLike | None = None
                 ) -> tuple[ArrF, ArrF]:
        """Dense ``(G, C)`` for the given parameter values."""
        v = self.values(values)
        self._check_values(v)
        q, _ = self._q(v)
        n2 = self.size * self.size
        w = self.t_coef * q[self.t_param]
        g = _scatter(self.t_flat[~self.t_is_c], w[~self.t_is_c], n2)
        g = g + np.bincount(self.fixed_g[0], self.fixed_g[1], minlength=n2)
        c = _scatter(self.t_flat[self.t_is_c], w[self.t_is_c], n2)
        return (np.asarray(g).reshape(self.size, self.size),
                np.asarray(c).reshape(self.size, self.size))

    # ------------------------------------------------------------------ inputs / outputs
    def input_matrix(self, inputs: Sequence[Excitation]) -> ArrF:
        """B (N, n_in): unit source amplitude or unit current injected into a node pair."""
        b = np.zeros((self.size, len(inputs)))
        for j, inp in enumerate(inputs):
            if isinstance(inp, tuple):
                p, n = (self._node(x, "input") for x in inp)
                if p >= 0:
                    b[p, j] += 1.0
                if n >= 0:
                    b[n, j] -= 1.0
                continue
            el = self.circuit.element(inp)
            if el.kind == "vsource":
                b[self.branch_index[inp], j] = 1.0
            elif el.kind == "isource":
                a, n = (self._node(x, "input") for x in el.nodes)
                if a >= 0:
                    b[a, j] -= 1.0
                if n >= 0:
                    b[n, j] += 1.0
            else:
                raise CircuitError(f"input {inp!r} is a {el.kind}; expected an independent "
                                   "source name or a node pair")
        return b

    def output_matrix(self, outputs: Sequence[Probe]) -> ArrF:
        """Cout (N, n_out): node voltage, node-pair voltage, or ``"i(name)"`` branch current."""
        c = np.zeros((self.size, len(outputs)))
        for j, out in enumerate(outputs):
            if isinstance(out, tuple):
                p, n = (self._node(x, "output") for x in out)
                if p >= 0:
                    c[p, j] += 1.0
                if n >= 0:
                    c[n, j] -= 1.0
            elif out.startswith("i(") and out.endswith(")"):
                name = out[2:-1]
                if name not in self.branch_index:
                    raise CircuitError(f"output {out!r}: {name!r} has no branch current "
                                       f"(expected a voltage source, inductor, switch, VCVS "
                                       f"or CCVS)")
                c[self.branch_index[name], j] = 1.0
            else:
                k = self._node(out, "output")
                if k >= 0:
                    c[k, j] = 1.0
        return c

    def _node(self, name: str, what: str) -> int:
        if name == self.circuit.ground:
            return -1
        try:
            return self.node_index[name]
        except KeyError:
            raise CircuitError(f"{what}: node {name!r} is not in the circuit") from None

    # ------------------------------------------------------------------ solving
    def solve(self, freq_hz: ArrayLike, b: ArrF, cout: ArrF,
              values: Mapping[str, float] | ArrayLike | None = None, *,
              adjoint: bool = False, method: SolveMethod = "auto") -> Solution:
        """Solve for all frequencies: ``H = Cout^T (G + sC)^-1 B`` (and x, lambda if adjoint).

        ``auto``: batched dense LU up to :data:`_DENSE_MAX` unknowns, sparse LU above.
        Measured (one BLAS thread, 200-300 frequencies, with the adjoint): random RLC
        networks of 40 unknowns 12 vs 13 ms, 58 unknowns 25 vs 18 ms; the grey-box
        networks of the detective (78-96 unknowns) 2.3-3.5x faster sparse."""
        f = _freq(freq_hz)
        g, c = self.matrices(values)
        s = np.asarray(2j * np.pi * f, dtype=np.complex128)
        direct: SolveMethod = "dense" if self.size <= _DENSE_MAX else "sparse"
        if method == "auto":
            method = direct
        if method == "hessenberg":
            sol = solve_hessenberg(g, c, s, b, cout, adjoint)
            if sol is not None:
                return sol
            method = direct
        if method == "modal":
            sol = solve_modal(g, c, s, b, cout, adjoint)
            if sol is not None:
                return sol
            method = direct
        if method == "dense":
            return solve_dense(g, c, s, b, cout, adjoint)
        if method == "sparse":
            return solve_sparse(g, c, s, b, cout, adjoint)
        raise InputError(f"method: got {method!r}; expected 'auto', 'dense', 'sparse', "
                         "'hessenberg' or 'modal'")

    def response(self, freq_hz: ArrayLike, inputs: Sequence[Excitation],
                 outputs: Sequence[Probe],
                 values: Mapping[str, float] | ArrayLike | None = None, *,
                 method: SolveMethod = "auto") -> ArrC:
        """Transfer matrix (n_freq, n_out, n_in) from ``inputs`` to ``outputs``.

        Inputs are independent-source names (unit amplitude; every other source is zero:
        voltage sources shorted, current sources open) or node pairs ``(p, n)`` (unit
        current into p out of n). Outputs are node names, node pairs or ``"i(name)"``.
        With node pairs on both sides this is the open-circuit impedance matrix.
        """
        sol = self.solve(freq_hz, self.input_matrix(inputs), self.output_matrix(outputs),
                         values, method=method)
        return sol.h

    def response_and_jacobian(
        self, freq_hz: ArrayLike, inputs: Sequence[Excitation], outputs: Sequence[Probe],
        values: Mapping[str, float] | ArrayLike | None = None, *,
        params: Sequence[str] | None = None, method: SolveMethod = "auto",
        diagonal: bool = False,
    ) -> tuple[ArrC, ArrC]:
        """Response and its derivatives by the adjoint method.

        Returns
        -------
        h : (n_freq, n_out, n_in) complex
        jac : (n_freq, n_out, n_in, n_params) complex
            ``d h / d value`` for ``params`` (default: all :attr:`param_names`); with
            ``diagonal`` (as many outputs as inputs) only ``d h[:, k, k] / d value``,
            shape (n_freq, n_out, n_params): the input impedances of several ports
            without the transfer impedances between them.
        """
        if diagonal and len(inputs) != len(outputs):
            raise InputError("diagonal: needs as many outputs as inputs",
                             found=f"{len(outputs)} outputs, {len(inputs)} inputs")
        v = self.values(values)
        sel = self._param_indices(params)
        sol = self.solve(freq_hz, self.input_matrix(inputs), self.output_matrix(outputs), v,
                         adjoint=True, method=method)
        assert sol.x is not None and sol.lam is not None
        s = np.asarray(2j * np.pi * _freq(freq_hz), dtype=np.complex128)
        _, dq = self._q(v)
        # the stamp quantities whose derivatives are needed: the selected parameters and
        # the mutual couplings of a selected inductor (M = k sqrt(L1 L2) depends on L1)
        need = set(sel.tolist())
        for mp, l1, l2 in zip(self.mut_params, self.mut_l1, self.mut_l2, strict=True):
            if l1 in need or l2 in need:
                need.add(int(mp))
        need_a = np.asarray(sorted(need), dtype=np.intp)
        col = np.full(len(self.param_names), -1, dtype=np.intp)
        col[need_a] = np.arange(need_a.size)
        # per triplet t: -lam[row_t] * coef_t * (s or 1) * x[col_t], summed per quantity:
        # the products lam x of the needed triplets times two sparse (triplet x quantity)
        # matrices of the coefficients (G and C triplets), in frequency chunks
        tsel = np.flatnonzero(col[self.t_param] >= 0)
        n_q = need_a.size
        n_t = tsel.size
        n_o, n_i = sol.lam.shape[2], sol.x.shape[2]
        pair_shape = (n_o,) if diagonal else (n_o, n_i)
        jac = np.zeros((s.size, *pair_shape, n_q), dtype=complex)
        if n_t:
            tix = np.arange(n_t)
            t_row, t_col = self.t_row[tsel], self.t_col[tsel]
            t_is_c, t_q = self.t_is_c[tsel], col[self.t_param[tsel]]
            mats = [sp.csr_array((np.where(t_is_c == is_c, self.t_coef[tsel], 0.0),
                                  (tix, t_q)), shape=(n_t, n_q))
                    for is_c in (False, True)]
            step = max(1, _CHUNK_BYTES // (32 * int(np.prod(pair_shape)) * n_t))
            s_b = s.reshape(-1, *([1] * (len(pair_shape) + 1)))
            for a in range(0, s.size, step):
                lr = np.swapaxes(sol.lam[a:a + step, t_row, :], 1, 2)        # (f, o, t)
                xc = np.swapaxes(sol.x[a:a + step, t_col, :], 1, 2)          # (f, i, t)
                prod = (lr * xc if diagonal
                        else lr[:, :, None, :] * xc[:, None, :, :]).reshape(-1, n_t)
                jg, jc = (np.asarray(prod @ m).reshape(-1, *pair_shape, n_q) for m in mats)
                jac[a:a + step] = -(jg + s_b[a:a + step] * jc)
        dsl = jac.copy()                                      # d h / d q
        jac *= dq[need_a]
        if self.mut_params.size:
            # M = k sqrt(L1 L2): dM/dL1 = M / (2 L1), dM/dL2 = M / (2 L2)
            m = v[self.mut_params] * np.sqrt(np.abs(v[self.mut_l1] * v[self.mut_l2]))
            for mp, l1, l2, mm in zip(self.mut_params, self.mut_l1, self.mut_l2, m,
                                      strict=True):
                for li in (l1, l2):
                    if col[li] >= 0:
                        jac[..., col[li]] += dsl[..., col[mp]] * mm / (2 * v[li])
        return sol.h, jac[..., col[sel]]

    def _param_indices(self, params: Sequence[str] | None) -> ArrI:
        """Indices of ``params`` in :attr:`param_names` (all when None)."""
        if params is None:
            return np.arange(len(self.param_names), dtype=np.intp)
        index = {n: i for i, n in enumerate(self.param_names)}
        try:
            return np.asarray([index[p] for p in params], dtype=np.intp)
        except KeyError as err:
            raise CircuitError(f"{err.args[0]!r} is not a parameter of the circuit") from None

    def ac(self, freq_hz: ArrayLike, outputs: Sequence[Probe],
           values: Mapping[str, float] | ArrayLike | None = None, *,
           method: SolveMethod = "auto") -> ArrC:
        """Outputs (n_freq, n_out) with every independent source at its AC amplitude."""
        sol = self.solve(freq_hz, self.ac_input[:, None], self.output_matrix(outputs), values,
                         method=method)
        return sol.h[:, :, 0]


@dataclass(frozen=True)
class CircuitTransfer:
    """``H(freq_hz) -> (n_freq, n_out, n_in)`` of a circuit (see :meth:`MnaSystem.response`).

    Usable wherever a model callable on frequencies is accepted (e.g. ``vfmodel.simulate``).
    """

    mna: MnaSystem
    inputs: tuple[Excitation, ...]
    outputs: tuple[Probe, ...]
    method: SolveMethod = "auto"
    values: ArrF | None = None     # parameter vector (default: the circuit's values)

    @property
    def n_in(self) -> int:
        return len(self.inputs)

    @property
    def n_out(self) -> int:
        return len(self.outputs)

    def __call__(self, freq_hz: ArrayLike) -> ArrC:
        return self.mna.response(freq_hz, self.inputs, self.outputs, self.values,
                                 method=self.method)


# ---------------------------------------------------------------------- kernels
def _scatter(idx: ArrI, w: NDArray[Any], n: int) -> NDArray[Any]:
    if np.iscomplexobj(w):
        return np.bincount(idx, w.real, minlength=n) + 1j * np.bincount(idx, w.imag, minlength=n)
    return np.bincount(idx, w, minlength=n)


def _freq(freq_hz: ArrayLike) -> ArrF:
    """Frequencies (Hz) as a 1-D array; negative values give s = -j w (conjugate side)."""
    f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    if f.ndim != 1 or not np.all(np.isfinite(f)):
        raise InputError("freq_hz must be a 1-D array of finite frequencies",
                         found=f"shape {f.shape}")
    return f
