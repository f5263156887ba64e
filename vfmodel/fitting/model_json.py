"""`model.json` of ``vfmodel fit`` (CONTRACT section 4): build, write atomically, read."""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vfmodel.core.rational_model import RationalModel
from vfmodel.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from vfmodel.fitting.vectfit import FitReport

__all__ = ["model_to_json", "read_model_json", "write_model_json"]


def _finite_or_none(x: float | None) -> float | None:
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


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
    must be True only for a certified model. Extra keys: ``order`` and ``order_reason``.
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
    return out


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
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as err:
        raise InputError(
            "not valid JSON", source=src, place=f"line {err.lineno}, column {err.colno}"
        ) from None
    if not isinstance(obj, dict):
        raise InputError("not a vfmodel model", source=src, expected="a JSON object")
    return RationalModel.from_json_dict(obj, source=src)
