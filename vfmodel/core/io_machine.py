"""Parsing the ``[machine]``, ``[bearing]`` and ``[priors]`` tables of ``dataset.toml``.

Called by :func:`vfmodel.core.io_dataset.read_dataset`; every error is an InputError that
names the file, the table and the key. Keys of ``[priors]`` are grey-box parameter names;
this layer checks their form, :func:`vfmodel.greybox.priors.check_overrides` their names.
"""

from __future__ import annotations

import math
from typing import Any

from vfmodel.core.machine_info import (
    BEARING_TYPES,
    BearingInfo,
    MachineInfo,
    PriorOverride,
    field_names,
)
from vfmodel.errors import InputError

__all__ = ["parse_bearing", "parse_machine", "parse_priors"]

_INTEGER_KEYS = ("slots", "balls", "pole_pairs")
_ZERO_ALLOWED = ("contact_angle_deg", "axial_load_n")
_CELSIUS = ("temperature_c",)
_LIMITS: dict[str, tuple[float, float]] = {
    "insulation_permittivity": (1.0, 20.0),
    "lubricant_permittivity": (1.0, 10.0),
    "inner_conformity": (0.5, 0.6),
    "outer_conformity": (0.5, 0.6),
    "contact_angle_deg": (0.0, 45.0),
    "slots": (3, 1000),
    "balls": (3, 100),
    "pole_pairs": (1, 100),
    "temperature_c": (-60.0, 250.0),
}
"""Physical ranges (inclusive) of the keys that have one; the rest must be > 0."""


def _table(doc: dict[str, Any], key: str, src: str) -> dict[str, Any] | None:
    t = doc.get(key)
    if t is None:
        return None
    if not isinstance(t, dict):
        raise InputError(f"[{key}] must be a table", source=src, found=type(t).__name__)
    return t


def _number(value: Any, key: str, src: str, place: str) -> float:
    if key in _INTEGER_KEYS:
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"key {key!r} must be an integer", source=src, place=place,
                             found=repr(value))
    elif isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"key {key!r} must be a number", source=src, place=place,
                         found=repr(value))
    x = float(value)
    lo, hi = _LIMITS.get(key, (0.0, math.inf))
    ok = math.isfinite(x) and lo <= x <= hi
    if key not in _LIMITS:
        ok = ok and (x >= 0 if key in _ZERO_ALLOWED else x > 0)
    if not ok:
        exp = f"a number in [{lo:g}, {hi:g}]" if key in _LIMITS else (
            "a finite number >= 0" if key in _ZERO_ALLOWED else "a finite number > 0")
        raise InputError(f"key {key!r} is out of range", source=src, place=place,
                         found=repr(value), expected=exp)
    return x


def _fields(table: dict[str, Any], cls: type, name: str, src: str) -> dict[str, Any]:
    allowed = field_names(cls)
    out: dict[str, Any] = {}
    for key, value in table.items():
        place = f"[{name}] {key}"
        if key not in allowed:
            raise InputError(f"unknown key {key!r}", source=src, place=f"[{name}]",
                             expected=", ".join(allowed))
        if key == "type":
            if value not in BEARING_TYPES:
                raise InputError("unknown bearing type", source=src, place=place,
                                 found=repr(value), expected=", ".join(BEARING_TYPES))
            out[key] = value
            continue
        x = _number(value, key, src, place)
        out[key] = int(x) if key in _INTEGER_KEYS else x
    return out


def parse_machine(doc: dict[str, Any], src: str) -> MachineInfo | None:
    """The ``[machine]`` table of a parsed ``dataset.toml`` (None when absent)."""
    t = _table(doc, "machine", src)
    return None if t is None else MachineInfo(**_fields(t, MachineInfo, "machine", src))


def parse_bearing(doc: dict[str, Any], src: str) -> BearingInfo | None:
    """The ``[bearing]`` table of a parsed ``dataset.toml`` (None when absent)."""
    t = _table(doc, "bearing", src)
    if t is None:
        return None
    info = BearingInfo(**_fields(t, BearingInfo, "bearing", src))
    if info.ball_diameter_m is not None and info.pitch_diameter_m is not None \
            and not info.ball_diameter_m < info.pitch_diameter_m / 2:
        raise InputError("ball diameter must be below half the pitch diameter", source=src,
                         place="[bearing] ball_diameter_m", found=f"{info.ball_diameter_m:g}",
                         expected=f"< {info.pitch_diameter_m / 2:g}")
    return info


_OVERRIDE_KEYS = ("median", "gsd", "lower", "upper")


def parse_priors(doc: dict[str, Any], src: str) -> dict[str, PriorOverride]:
    """The ``[priors]`` table: parameter name -> ``{median, gsd}`` or ``{lower, upper}``."""
    t = _table(doc, "priors", src)
    out: dict[str, PriorOverride] = {}
    for name, entry in (t or {}).items():
        place = f"[priors] {name!r}"
        if not isinstance(entry, dict):
            raise InputError("prior override must be a table", source=src, place=place,
                             found=repr(entry)[:40],
                             expected="{ median = ..., gsd = ... } or { lower = ..., upper = ... }")
        unknown = sorted(set(entry) - set(_OVERRIDE_KEYS))
        if unknown:
            raise InputError(f"unknown key {unknown[0]!r}", source=src, place=place,
                             expected="median and gsd, or lower and upper")
        keys = set(entry)
        if keys not in ({"median", "gsd"}, {"lower", "upper"}):
            raise InputError("a prior override needs exactly median and gsd, or lower and "
                             "upper", source=src, place=place, found=", ".join(sorted(keys)))
        v: dict[str, float] = {}
        for k, x in entry.items():
            if isinstance(x, bool) or not isinstance(x, int | float) or \
                    not (math.isfinite(float(x)) and float(x) > 0):
                raise InputError(f"key {k!r} must be a finite number > 0", source=src,
                                 place=place, found=repr(x))
            v[k] = float(x)
        if "gsd" in v and not v["gsd"] > 1:
            raise InputError("gsd (geometric standard deviation) must be > 1", source=src,
                             place=place, found=f"{v['gsd']:g}")
        if "lower" in v and not v["lower"] < v["upper"]:
            raise InputError("lower must be below upper", source=src, place=place,
                             found=f"lower {v['lower']:g}, upper {v['upper']:g}")
        out[str(name)] = PriorOverride(**v)
    return out
