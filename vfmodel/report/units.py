"""Engineering notation for reports: ``1.015e-08 F`` -> ``10.15 nF``.

:func:`si` writes a number with an SI prefix and four significant digits, :func:`parse_si`
reads such a text back (the browser test compares the page's text with ``results.json``
through it), :func:`si_interval` writes a value with its 95 % interval.
"""

from __future__ import annotations

import math
import re

__all__ = ["PREFIXES", "parse_si", "si", "si_interval"]

PREFIXES = {-18: "a", -15: "f", -12: "p", -9: "n", -6: "µ", -3: "m", 0: "", 3: "k",
            6: "M", 9: "G", 12: "T", 15: "P"}
"""Exponent -> prefix (the micro sign U+00B5 for 1e-6; :func:`parse_si` also reads ``u``)."""

_NO_PREFIX = {"", "%", "deg", "rpm", "dB"}
"""Units written without a prefix (``1.343 %``, ``500 rpm``)."""



def _finite_text(x: float) -> str | None:
    if math.isnan(x):
        return "n/a"
    if math.isinf(x):
        return "∞" if x > 0 else "-∞"
    return None


def si(x: float | int | None, unit: str = "", digits: int = 4) -> str:
    """``x`` with ``digits`` significant digits and an SI prefix on ``unit``.

    ``si(1.015e-8, "F") == "10.15 nF"``, ``si(31630, "Ω") == "31.63 kΩ"``,
    ``si(1.343, "%") == "1.343 %"``, ``si(0.99959) == "0.9996"``; ``None`` gives ``"–"``,
    NaN ``"n/a"`` and infinity ``"∞"``. Units in ``_NO_PREFIX`` (%, deg, rpm, dB and
    dimensionless numbers) take no prefix; their numbers use plain ``g`` notation, with
    an exponent only outside [1e-4, 1e6).
    """
    if x is None:
        return "–"
    x = float(x)
    special = _finite_text(x)
    if special is not None:
        return f"{special} {unit}".rstrip()
    sep = " " if unit else ""
    if unit in _NO_PREFIX:
        if x != 0 and not 1e-4 <= abs(x) < 1e6:
            return f"{x:.{digits - 1}e}{sep}{unit}"
        return f"{x:.{digits}g}{sep}{unit}"
    if x == 0:
        return f"0{sep}{unit}"
    exp3 = 3 * math.floor(math.log10(abs(x)) / 3)
    exp3 = min(max(exp3, min(PREFIXES)), max(PREFIXES))
    mant = x / 10.0**exp3
    text = f"{mant:.{digits}g}"
    if abs(float(text)) >= 1000 and exp3 + 3 in PREFIXES:  # 999.96 rounds to 1000
        exp3 += 3
        text = f"{x / 10.0**exp3:.{digits}g}"
    if "e" in text:  # beyond the prefix range
        return f"{x:.{digits - 1}e}{sep}{unit}"
    return f"{text} {PREFIXES[exp3]}{unit}"


def si_interval(value: float | None, lo: float | None, hi: float | None,
                unit: str = "") -> str:
    """``"45.15 kΩ (95 %: 16.98 kΩ … 120.1 kΩ)"``; without bounds the value alone."""
    if lo is None or hi is None:
        return si(value, unit)
    return f"{si(value, unit)} (95 %: {si(lo, unit)} … {si(hi, unit)})"


_NUM = re.compile(r"^\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(\S*)\s*$")
_BY_PREFIX = {v: k for k, v in PREFIXES.items() if v}
_BY_PREFIX["u"] = -6
_BY_PREFIX["μ"] = -6  # Greek mu


def parse_si(text: str, unit: str = "") -> float:
    """The number written by :func:`si`: ``parse_si("10.15 nF", "F") == 1.015e-08``.

    ``unit`` is the unit expected after the prefix (``""`` for none); ValueError when the
    text is not such a number.
    """
    t = text.strip().replace("−", "-")
    if t in ("∞", f"∞ {unit}".strip()):
        return math.inf
    m = _NUM.match(t)
    if m is None:
        raise ValueError(f"not a number with an SI prefix: {text!r}")
    num, rest = float(m.group(1)), m.group(2)
    if unit and rest.endswith(unit):
        rest = rest[: len(rest) - len(unit)]
    elif unit and unit not in _NO_PREFIX:
        raise ValueError(f"{text!r}: expected the unit {unit!r}")
    if unit in _NO_PREFIX or rest == "":
        if rest not in ("", unit):
            raise ValueError(f"{text!r}: unexpected {rest!r}")
        return num
    if rest not in _BY_PREFIX:
        raise ValueError(f"{text!r}: unknown SI prefix {rest!r}")
    return num * 10.0 ** _BY_PREFIX[rest]
