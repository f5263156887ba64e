"""`RationalModel`: pole-residue model H(s) = sum_k R_k/(s - p_k) + D + s E."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vfmodel._choices import KINDS, Kind
from vfmodel.errors import InputError

_PAIR_TOL = 1e-9


@dataclass(frozen=True)
class StateSpace:
    """Real state-space realisation: H(s) = C (sI - A)^-1 B + D + s E."""

    a: NDArray[np.float64]
    b: NDArray[np.float64]
    c: NDArray[np.float64]
    d: NDArray[np.float64]
    e: NDArray[np.float64]


def _canonical_order(
    poles: NDArray[np.complex128], residues: NDArray[np.complex128], src: str
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """Order poles as: real poles, then each upper pole followed by its conjugate.

    Raises InputError when a complex pole has no conjugate partner with a conjugate residue.
    """
    scale = np.maximum(np.abs(poles), 1e-300)
    is_real = np.abs(poles.imag) <= _PAIR_TOL * scale
    k = int(np.count_nonzero(is_real))
    if _in_canonical_order(poles, residues, scale, is_real, k):
        idx: list[int] | slice = slice(None)  # a fit's model: no search
    else:
        idx = _search_pairs(poles, residues, scale, is_real, src)
    p = poles[idx].copy()
    r = residues[idx].copy()
    p[:k] = p[:k].real
    r[:k] = r[:k].real
    # make the pairs exactly conjugate
    p[k + 1 :: 2] = np.conj(p[k::2])
    r[k + 1 :: 2] = np.conj(r[k::2])
    return p, r


def _in_canonical_order(
    poles: NDArray[np.complex128], residues: NDArray[np.complex128],
    scale: NDArray[np.float64], is_real: NDArray[np.bool_], k: int,
) -> bool:
    """True when the ``k`` real poles come first and every upper pole is followed by its
    conjugate with a conjugate residue, within :func:`_search_pairs`' tolerances."""
    up, lo = poles[k::2], poles[k + 1 :: 2]
    if not (bool(np.all(is_real[:k])) and up.size == lo.size and bool(np.all(up.imag > 0))
            and bool(np.all(np.abs(lo - up.conj()) <= 1e-6 * scale[k::2]))):
        return False
    if up.size == 0:
        return True
    r_up, r_lo = residues[k::2], residues[k + 1 :: 2]
    rscale = np.maximum(np.max(np.abs(r_up).reshape(up.size, -1), axis=1), 1e-300)
    miss = np.max(np.abs(r_lo - r_up.conj()).reshape(up.size, -1), axis=1)
    return bool(np.all(miss <= 1e-6 * rscale))  # else the search names the pair


def _search_pairs(
    poles: NDArray[np.complex128], residues: NDArray[np.complex128],
    scale: NDArray[np.float64], is_real: NDArray[np.bool_], src: str,
) -> list[int]:
    """The canonical order's indices: the real poles, then each upper pole and its
    conjugate found among the lower ones (InputError for an unpaired pole or residue)."""
    order: list[int] = [int(i) for i in np.flatnonzero(is_real)]
    upper = [int(i) for i in np.flatnonzero(~is_real & (poles.imag > 0))]
    lower = {int(i) for i in np.flatnonzero(~is_real & (poles.imag < 0))}
    pairs: list[int] = []
    for i in upper:
        match = None
        for j in lower:
            if abs(poles[j] - np.conj(poles[i])) <= 1e-6 * scale[i]:
                match = j
                break
        if match is None:
            raise InputError(
                "complex pole without its conjugate",
                source=src,
                found=f"pole {poles[i]:.6g}",
                expected="conjugate pairs listed explicitly",
            )
        lower.remove(match)
        rscale = max(float(np.max(np.abs(residues[i]))), 1e-300)
        if np.max(np.abs(residues[match] - np.conj(residues[i]))) > 1e-6 * rscale:
            raise InputError(
                "residues of a conjugate pole pair are not conjugate",
                source=src,
                found=f"pole {poles[i]:.6g}",
            )
        pairs += [i, match]
    if lower:
        j = next(iter(lower))
        raise InputError(
            "complex pole without its conjugate", source=src, found=f"pole {poles[j]:.6g}"
        )
    return order + pairs


@dataclass(frozen=True)
class RationalModel:
    """Pole-residue rational model (CONTRACT section 4).

    ``H(s) = (sum_k residues[k] / (s - poles[k]) + d + s * e) exp(-s delay)`` with
    ``s = j 2 pi f``.
    Poles are rad/s; complex poles come in explicitly listed conjugate pairs with conjugate
    residues. The constructor orders poles canonically: real poles first, then each pole with
    positive imaginary part followed by its conjugate.

    Parameters
    ----------
    poles : (n_poles,) complex
    residues : (n_poles, n_out, n_in) complex
    d, e : (n_out, n_in) real, default zero
    kind : {"Z", "Y", "S", "H"}
    z0 : float, optional (S models)
    delay : float, default 0
        Common delay in seconds (S and H models only; 0 = none). The rational part is
        what :meth:`to_state_space` realises; the delay multiplies it. An S model's delay
        is realised in SPICE by matched lossless lines of delay/2 at every port.
    """

    poles: NDArray[np.complex128]
    residues: NDArray[np.complex128]
    d: NDArray[np.float64] | None = None
    e: NDArray[np.float64] | None = None
    kind: Kind = "Z"
    z0: float | None = None
    delay: float = 0.0

    def __post_init__(self) -> None:
        src = "RationalModel"
        tau = float(self.delay)
        if not (np.isfinite(tau) and tau >= 0):
            raise InputError("delay must be finite and >= 0", source=src, found=repr(self.delay))
        if tau > 0 and self.kind in ("Z", "Y"):
            raise InputError(
                "a delay is supported for S and H models only",
                source=src,
                found=f"kind {self.kind!r} with delay {tau:g} s",
                expected="delay 0 for Z/Y (a delayed immittance is not positive real)",
            )
        object.__setattr__(self, "delay", tau)
        if self.kind not in KINDS:
            raise InputError("unknown kind", source=src, found=repr(self.kind))
        p = np.atleast_1d(np.asarray(self.poles, dtype=complex))
        r = np.asarray(self.residues, dtype=complex)
        if p.ndim != 1:
            raise InputError("poles must be 1-D", source=src, found=f"shape {p.shape}")
        if r.ndim == 1:
            r = r[:, None, None]
        if r.ndim != 3 or r.shape[0] != p.size:
            raise InputError(
                "residues must have shape (n_poles, n_out, n_in)",
                source=src,
                found=f"{np.shape(self.residues)} for {p.size} poles",
            )
        n_out, n_in = r.shape[1], r.shape[2]
        if p.size == 0 and self.d is not None:
            n_out, n_in = np.atleast_2d(np.asarray(self.d, dtype=float)).shape
            r = np.zeros((0, n_out, n_in), complex)
        d = np.zeros((n_out, n_in)) if self.d is None else np.asarray(self.d, dtype=float)
        e = np.zeros((n_out, n_in)) if self.e is None else np.asarray(self.e, dtype=float)
        d = d.reshape(n_out, n_in) if d.size == n_out * n_in else d
        e = e.reshape(n_out, n_in) if e.size == n_out * n_in else e
        if d.shape != (n_out, n_in) or e.shape != (n_out, n_in):
            raise InputError(
                "d and e must have shape (n_out, n_in)",
                source=src,
                found=f"d {d.shape}, e {e.shape}",
                expected=str((n_out, n_in)),
            )
        for name, arr in (("poles", p), ("residues", r), ("d", d), ("e", e)):
            if not np.all(np.isfinite(arr)):
                raise InputError(f"{name} contain NaN or infinity", source=src)
        p, r = _canonical_order(p, r, src)
        z0 = self.z0
        if self.kind == "S":
            z0 = 50.0 if z0 is None else float(z0)
        for arr in (p, r, d, e):
            arr.setflags(write=False)
        object.__setattr__(self, "poles", p)
        object.__setattr__(self, "residues", r)
        object.__setattr__(self, "d", d)
        object.__setattr__(self, "e", e)
        object.__setattr__(self, "z0", z0)

    # ------------------------------------------------------------------ properties
    @property
    def n_poles(self) -> int:
        return int(self.poles.size)

    @property
    def n_out(self) -> int:
        return int(self.residues.shape[1])

    @property
    def n_in(self) -> int:
        return int(self.residues.shape[2])

    @property
    def dd(self) -> NDArray[np.float64]:
        """``d`` as a non-optional array (for type checkers)."""
        assert self.d is not None
        return self.d

    @property
    def ee(self) -> NDArray[np.float64]:
        """``e`` as a non-optional array (for type checkers)."""
        assert self.e is not None
        return self.e

    @property
    def is_stable(self) -> bool:
        """True when every pole lies strictly in the left half plane."""
        return bool(np.all(self.poles.real < 0))

    # ------------------------------------------------------------------ evaluation
    def evaluate_s(self, s: ArrayLike) -> NDArray[np.complex128]:
        """H at complex frequencies ``s`` (rad/s): shape (n_s, n_out, n_in)."""
        s = np.atleast_1d(np.asarray(s, dtype=complex))
        # (n_s, n_poles) @ (n_poles, n_out*n_in)
        basis = 1.0 / (s[:, None] - self.poles[None, :])
        h = (basis @ self.residues.reshape(self.n_poles, self.n_out * self.n_in)).reshape(
            s.size, self.n_out, self.n_in
        )
        h = h + self.dd[None] + s[:, None, None] * self.ee[None]
        if self.delay:
            h = h * np.exp(-s * self.delay)[:, None, None]
        return h

    def without_delay(self) -> RationalModel:
        """The rational part alone (delay 0)."""
        return RationalModel(self.poles, self.residues, self.d, self.e, self.kind, self.z0)

    def __call__(self, freq_hz: ArrayLike) -> NDArray[np.complex128]:
        """H(j 2 pi f): shape (n_freq, n_out, n_in)."""
        f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
        return self.evaluate_s(2j * np.pi * f)

    def to_network(self, freq_hz: ArrayLike, z0: float | None = None) -> Any:
        """The model's response at ``freq_hz`` as a :class:`skrf.Network` (S-parameters at
        ``z0``, default the model's own z0 or 50 ohm); ``write_touchstone`` on it gives a
        Touchstone file. Z, Y and S models only."""
        from vfmodel.core.frequency_data import FrequencyData

        if self.kind == "H" or self.n_out != self.n_in:
            raise InputError(
                "only square Z, Y or S models are networks",
                source="RationalModel.to_network",
                found=f"{self.kind} {self.n_out}x{self.n_in}",
            )
        f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
        data = FrequencyData(f, self(f), kind=self.kind, z0=self.z0)
        return data.to_network(z0=z0)

    # ------------------------------------------------------------------ realisation
    def to_state_space(self) -> StateSpace:
        """Real realisation (A, B, C, D, E) of the rational part (without ``delay``),
        n_in states per real pole, 2 n_in per pair.

        A complex pair p = a + jb with residue R = R' + jR'' is realised with
        A = [[a I, b I], [-b I, a I]], B = [[2 I], [0]], C = [R', R''], which gives
        C (sI - A)^-1 B = R/(s - p) + conj(R)/(s - conj(p)).
        """
        n_in, n_out = self.n_in, self.n_out
        n_real = int(np.sum(self.poles.imag == 0))
        n_pairs = (self.n_poles - n_real) // 2
        n_x = (n_real + 2 * n_pairs) * n_in
        a = np.zeros((n_x, n_x))
        b = np.zeros((n_x, n_in))
        c = np.zeros((n_out, n_x))
        eye = np.eye(n_in)
        k = 0
        for i in range(n_real):
            sl = slice(k, k + n_in)
            a[sl, sl] = self.poles[i].real * eye
            b[sl] = eye
            c[:, sl] = self.residues[i].real
            k += n_in
        for j in range(n_pairs):
            i = n_real + 2 * j
            pr, pi = self.poles[i].real, self.poles[i].imag
            s1, s2 = slice(k, k + n_in), slice(k + n_in, k + 2 * n_in)
            a[s1, s1] = pr * eye
            a[s1, s2] = pi * eye
            a[s2, s1] = -pi * eye
            a[s2, s2] = pr * eye
            b[s1] = 2 * eye
            c[:, s1] = self.residues[i].real
            c[:, s2] = self.residues[i].imag
            k += 2 * n_in
        return StateSpace(a, b, c, self.dd.copy(), self.ee.copy())

    # ------------------------------------------------------------------ JSON
    def _repr_html_(self) -> str:
        """Compact summary in Jupyter (:mod:`vfmodel.report.notebook`)."""
        from vfmodel.report.notebook import model_html

        return model_html(self)

    def plot(self, freq_hz: ArrayLike | None = None, ax: Any = None) -> Any:
        """|H| of the entries (matplotlib imported now); returns the axes."""
        from vfmodel.report.notebook import model_plot

        return model_plot(self, freq_hz, ax)

    def to_json_dict(self) -> dict[str, Any]:
        """The model fields of CONTRACT section 4 (without fit statistics)."""
        return {
            "kind": self.kind,
            "z0": self.z0,
            "n_out": self.n_out,
            "n_in": self.n_in,
            "poles": [[float(p.real), float(p.imag)] for p in self.poles],
            "residues": [
                [[[float(x.real), float(x.imag)] for x in row] for row in r]
                for r in self.residues
            ],
            "d": self.dd.tolist(),
            "e": self.ee.tolist(),
            "delay_s": self.delay,
        }

    @classmethod
    def from_json_dict(cls, obj: dict[str, Any], source: str = "model.json") -> RationalModel:
        """Inverse of :meth:`to_json_dict` (extra keys are ignored)."""
        try:
            n_out, n_in = int(obj["n_out"]), int(obj["n_in"])
            poles = np.array([complex(a, b) for a, b in obj["poles"]], dtype=complex)
            res = np.array(obj["residues"], dtype=float).reshape(poles.size, n_out, n_in, 2)
            residues = res[..., 0] + 1j * res[..., 1]
            return cls(
                poles=poles,
                residues=residues,
                d=np.array(obj["d"], dtype=float).reshape(n_out, n_in),
                e=np.array(obj["e"], dtype=float).reshape(n_out, n_in),
                kind=obj["kind"],
                z0=obj.get("z0"),
                delay=float(obj.get("delay_s") or 0.0),
            )
        except (KeyError, TypeError, ValueError) as err:
            if isinstance(err, InputError):
                raise
            raise InputError(
                f"not a vfmodel model: {err}",
                source=source,
                expected="keys kind, n_out, n_in, poles, residues, d, e (CONTRACT section 4)",
            ) from None
