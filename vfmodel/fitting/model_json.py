"""`model.json` of ``vfmodel fit`` (CONTRACT section 4): build, write atomically, read.

The file is strict JSON: no ``Infinity`` or ``NaN`` token anywhere. An unbounded value is
written as ``null``: the upper edge of a passivity violation band that extends to infinite
frequency (``"bands_hz": [[1e9, null]]``), a worst violation that occurs at infinite
frequency (``"worst_freq_hz": null`` beside a positive ``"worst_violation"``, i.e. in D),
and any statistic that is not defined (no data, not checked).
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from vfmodel.fitting.vectfit import FitReport

__all__ = [
    "json_safe",
    "model_to_json",
    "passivity_to_json",
    "read_model_json",
    "write_model_json",
]


def _finite_or_none(x: float | None) -> float | None:
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def json_safe(obj: Any) -> Any:
    """``obj`` with every non-finite float replaced by None (strict JSON, see the module
    docstring), tuples as lists and numpy scalars as Python numbers."""
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [json_safe(v) for v in obj]
    if isinstance(obj, bool | str) or obj is None:
        return obj
    if isinstance(obj, int | np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    try:
        x = float(obj)
    except (TypeError, ValueError):
        return obj
    return x if math.isfinite(x) else None


def passivity_to_json(report: Any, unconstrained_rel_rms_error: float | None = None,
                      data_floor: Any = None) -> dict[str, Any]:
    """The ``passivity`` object of ``model.json``.

    Keys: ``passive`` (certified: Hamiltonian test and its sampling cross-check agree),
    ``method``, ``bands_hz`` (list of [lo, hi]; hi null = the band extends to infinite
    frequency), ``worst_violation`` (>= 0: -min eig Re H for Z/Y, sigma_max - 1 for S),
    ``worst_freq_hz`` (null at infinite frequency or when passive), ``min_margin`` (the
    smallest margin found by the sampling cross-check, negative = violation),
    ``enforcement_iterations``, ``unconstrained_rel_rms_error`` (error before
    enforcement), ``data_floor`` (the data's own violation floor, see
    :mod:`vfmodel.fitting.data_passivity`), ``data_worst_violation``, ``data_active``.
    """
    out: dict[str, Any] = {
        "passive": bool(report.passive),
        "method": report.method,
        "bands_hz": [[lo, hi] for lo, hi in report.bands_hz],
        "worst_violation": report.worst_violation,
        "worst_freq_hz": report.worst_freq_hz if report.worst_violation > 0 else None,
        "min_margin": report.min_margin,
        "enforcement_iterations": report.iterations,
        "unconstrained_rel_rms_error": unconstrained_rel_rms_error,
        "notes": list(report.notes),
    }
    if data_floor is not None:
        out["data_floor"] = data_floor.floor
        out["data_worst_violation"] = data_floor.worst_violation
        out["data_active"] = bool(data_floor.active)
    result: dict[str, Any] = json_safe(out)
    return result


def model_to_json(
    model: RationalModel,
    report: FitReport | None,
    freq_range_hz: tuple[float, float],
    passive: bool | None,
) -> dict[str, Any]:
    """The ``model.json`` object of CONTRACT section 4.

    ``rms_error`` = sqrt(mean |H_model - H_data|^2) and ``rel_rms_error`` =
    ||H_model - H_data||_F / ||H_data||_F over all frequencies and entries, taken from
    ``report`` (None when no report is given). ``passive`` is None when not checked and
    must be True only for a certified model. Extra keys: ``order``, ``order_reason``,
    ``weighting``, ``point_rel_rms_error`` and ``point_rel_max_error`` (RMS and maximum
    over frequency of ||H_model(f) - H_data(f)||_F / ||H_data(f)||_F).
    """
    lo, hi = (float(freq_range_hz[0]), float(freq_range_hz[1]))
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo <= hi):
        raise InputError(
            "freq_range_hz must be two finite frequencies lo <= hi",
            found=str(freq_range_hz),
        )
    out = model.to_json_dict()
    out["freq_range_hz"] = [lo, hi]
    out["rms_error"] = _finite_or_none(report.rms_error) if report is not None else None
    out["rel_rms_error"] = _finite_or_none(report.rel_rms_error) if report is not None else None
    out["passive"] = None if passive is None else bool(passive)
    out["order"] = model.n_poles
    if report is not None:
        out["order_reason"] = report.order_reason
        out["weighting"] = report.weighting
        out["point_rel_rms_error"] = _finite_or_none(report.point_rel_rms_error)
        out["point_rel_max_error"] = _finite_or_none(report.point_rel_max_error)
        out["fit_notes"] = list(report.notes)
    result: dict[str, Any] = json_safe(out)
    return result


def write_model_json(
    path: str | os.PathLike[str],
    model: RationalModel,
    report: FitReport | None,
    freq_range_hz: tuple[float, float],
    passive: bool | None,
) -> Path:
    """Write ``model.json`` atomically (temporary file in the same directory, then
    :func:`os.replace`), so that a reader never sees a partial file. Returns the path."""
    obj = model_to_json(model, report, freq_range_hz, passive)
    dst = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{dst.name}.", suffix=".tmp", dir=dst.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(obj, fh, indent=1, allow_nan=False)
            fh.write("\n")
        os.replace(tmp, dst)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return dst


def read_model_json(path: str | os.PathLike[str]) -> RationalModel:
    """Read the model of a ``model.json`` file (CONTRACT section 4)."""
    src = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as err:
        raise InputError(f"cannot read model file: {err.strerror}", source=src) from None
    def no_constant(token: str) -> float:
        # Python's json accepts NaN/Infinity tokens; model.json is strict JSON
        raise InputError("not strict JSON", source=src, found=f"the token {token}",
                         expected="finite numbers (an unbounded value is null)")

    try:
        obj = json.loads(text, parse_constant=no_constant)
    except json.JSONDecodeError as err:
        raise InputError(
            "not valid JSON", source=src, place=f"line {err.lineno}, column {err.colno}"
        ) from None
    if not isinstance(obj, dict):
        raise InputError("not a vfmodel model", source=src, expected="a JSON object")
    try:
        return RationalModel.from_json_dict(obj, source=src)
    except (InputError, ValueError, TypeError) as err:
        # every message names the file, whichever check refused the content
        if isinstance(err, InputError) and src in str(err):
            raise
        raise InputError(str(err), source=src) from None
