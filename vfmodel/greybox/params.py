"""Physical parameters of the grey-box network: specification table and value sets.

Every parameter is positive with physical bounds ``lower <= value <= upper``; the
identification works on ``x = log(value)`` (or on ``u = (log v - log lo)/(log hi - log lo)``
in [0, 1]), so decades of uncertainty are searched uniformly and positivity holds.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vfmodel.errors import InputError

__all__ = ["ParamSet", "ParamSpec"]

ArrF = NDArray[np.float64]


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: ``name`` (dotted, e.g. ``winding.U.R_w``), nominal value and bounds.

    Attributes
    ----------
    name : str
    nominal : float
    lower, upper : float
        Physical bounds, ``0 < lower <= nominal <= upper``.
    group : str
        Substructure group (``winding.U``, ``insulation``, ``frame``, ``shaft``, ``bearing``,
        ``bearing.contact``, ``lubricant``, ``fixture``); identification stages select
        parameters by group (the speed-dependent ones: ``assembly.SPEED_GROUPS``).
    unit : str
    description : str
    """

    name: str
    nominal: float
    lower: float
    upper: float
    group: str
    unit: str = ""
    description: str = ""

    def __post_init__(self) -> None:
        if not (0 < self.lower <= self.nominal <= self.upper) or not np.isfinite(self.upper):
            raise InputError(
                "parameter bounds must satisfy 0 < lower <= nominal <= upper < inf",
                place=f"parameter {self.name}",
                found=f"lower={self.lower!r}, nominal={self.nominal!r}, upper={self.upper!r}",
            )


@dataclass(frozen=True)
class ParamSet:
    """An ordered table of :class:`ParamSpec` with current values.

    Build with :meth:`from_specs`; every modifier returns a new ``ParamSet``.
    """

    specs: tuple[ParamSpec, ...]
    values: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.specs) != len(self.values):
            raise InputError("ParamSet: specs and values differ in length",
                             found=f"{len(self.specs)} specs, {len(self.values)} values")
        names = [s.name for s in self.specs]
        if len(set(names)) != len(names):
            dup = next(n for n in names if names.count(n) > 1)
            raise InputError("ParamSet: parameter name used twice", place=dup)
        for s, v in zip(self.specs, self.values, strict=True):
            if not (np.isfinite(v) and v > 0):
                raise InputError("parameter value must be finite and > 0",
                                 place=f"parameter {s.name}", found=repr(v))

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_specs(cls, specs: Iterable[ParamSpec]) -> ParamSet:
        """Parameter set at the nominal values."""
        sp = tuple(specs)
        return cls(sp, tuple(float(s.nominal) for s in sp))

    # ------------------------------------------------------------------ access
    @property
    def names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.specs)

    def __len__(self) -> int:
        return len(self.specs)

    def __contains__(self, name: object) -> bool:
        return name in self.names

    def __getitem__(self, name: str) -> float:
        try:
            return self.values[self.names.index(name)]
        except ValueError:
            raise InputError("unknown parameter", place=name) from None

    def get(self, name: str, default: float) -> float:
        """Value of ``name`` or ``default`` when the set does not hold it."""
        return self[name] if name in self.names else default

    def as_dict(self) -> dict[str, float]:
        return dict(zip(self.names, self.values, strict=True))

    def spec(self, name: str) -> ParamSpec:
        return self.specs[self.names.index(name)] if name in self.names else \
            self._missing(name)

    def _missing(self, name: str) -> ParamSpec:
        raise InputError("unknown parameter", place=name)

    @property
    def lower(self) -> ArrF:
        return np.array([s.lower for s in self.specs])

    @property
    def upper(self) -> ArrF:
        return np.array([s.upper for s in self.specs])

    @property
    def vector(self) -> ArrF:
        return np.array(self.values, dtype=float)

    def names_in(self, groups: Sequence[str]) -> tuple[str, ...]:
        """Parameter names whose group equals or starts with ``g + '.'`` for a ``g``."""
        out = []
        for s in self.specs:
            if any(s.group == g or s.group.startswith(g + ".") for g in groups):
                out.append(s.name)
        return tuple(out)

    # ------------------------------------------------------------------ modification
    def with_values(self, values: Mapping[str, float], *, clip: bool = False) -> ParamSet:
        """New set with the named values changed (unknown names are an error).

        With ``clip`` values are clipped into the bounds, otherwise out-of-bound values
        are an error.
        """
        names = self.names
        v = list(self.values)
        for k, x in values.items():
            if k not in names:
                raise InputError("unknown parameter", place=k,
                                 expected="one of " + ", ".join(names))
            i = names.index(k)
            s = self.specs[i]
            x = float(x)
            if clip:
                x = float(np.clip(x, s.lower, s.upper))
            elif not (s.lower <= x <= s.upper):
                raise InputError("parameter value outside its bounds", place=k,
                                 found=repr(x), expected=f"[{s.lower:g}, {s.upper:g}]")
            v[i] = x
        return replace(self, values=tuple(v))

    def with_vector(self, x: ArrayLike, names: Sequence[str] | None = None) -> ParamSet:
        """New set with the values of ``names`` (default: all) from vector ``x``."""
        sel = self.names if names is None else tuple(names)
        xv = np.asarray(x, dtype=float).ravel()
        if xv.size != len(sel):
            raise InputError("parameter vector has the wrong length",
                             found=str(xv.size), expected=str(len(sel)))
        return self.with_values(dict(zip(sel, xv.tolist(), strict=True)))

    def with_specs(self, specs: Iterable[ParamSpec]) -> ParamSet:
        """Add (at their nominal values) or replace specifications, keeping other values."""
        new = list(self.specs)
        vals = list(self.values)
        for s in specs:
            if s.name in self.names:
                i = self.names.index(s.name)
                new[i] = s
                vals[i] = float(np.clip(vals[i], s.lower, s.upper))
            else:
                new.append(s)
                vals.append(s.nominal)
        return ParamSet(tuple(new), tuple(vals))

    def subset(self, names: Iterable[str]) -> ParamSet:
        keep = set(names)
        idx = [i for i, n in enumerate(self.names) if n in keep]
        return ParamSet(tuple(self.specs[i] for i in idx), tuple(self.values[i] for i in idx))

    # ------------------------------------------------------------------ log scaling
    def to_log(self, names: Sequence[str] | None = None) -> ArrF:
        """``log(value)`` of ``names`` (default all)."""
        sel = self.names if names is None else tuple(names)
        return np.log(np.array([self[n] for n in sel]))

    def from_log(self, x: ArrayLike, names: Sequence[str] | None = None, *,
                 clip: bool = True) -> ParamSet:
        """New set with ``value = exp(x)`` for ``names`` (default all)."""
        sel = self.names if names is None else tuple(names)
        xv = np.exp(np.asarray(x, dtype=float).ravel())
        if xv.size != len(sel):
            raise InputError("parameter vector has the wrong length",
                             found=str(xv.size), expected=str(len(sel)))
        return self.with_values(dict(zip(sel, xv.tolist(), strict=True)), clip=clip)

    def log_bounds(self, names: Sequence[str] | None = None) -> tuple[ArrF, ArrF]:
        """``(log lower, log upper)`` of ``names`` (default all)."""
        sel = self.names if names is None else tuple(names)
        specs = [self.spec(n) for n in sel]
        return (np.log([s.lower for s in specs]), np.log([s.upper for s in specs]))

    def to_unit(self, names: Sequence[str] | None = None) -> ArrF:
        """Position in the log box, ``(log v - log lo) / (log hi - log lo)`` (0.5 if fixed)."""
        lo, hi = self.log_bounds(names)
        x = self.to_log(names)
        span = hi - lo
        return np.where(span > 0, (x - lo) / np.where(span > 0, span, 1.0), 0.5)

    def from_unit(self, u: ArrayLike, names: Sequence[str] | None = None) -> ParamSet:
        """Inverse of :meth:`to_unit` (clipped to [0, 1])."""
        lo, hi = self.log_bounds(names)
        uu = np.clip(np.asarray(u, dtype=float).ravel(), 0.0, 1.0)
        return self.from_log(lo + uu * (hi - lo), names)

    def perturbed(self, rng: np.random.Generator, sigma_log: float,
                  names: Sequence[str] | None = None) -> ParamSet:
        """Log-normal perturbation ``v exp(sigma_log N(0,1))`` of ``names``, clipped to bounds."""
        sel = self.names if names is None else tuple(names)
        x = self.to_log(sel) + sigma_log * rng.standard_normal(len(sel))
        return self.from_log(x, sel, clip=True)
