"""Reading a dataset directory (``dataset.toml``, CONTRACT section 2)."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from vfmodel._choices import TOPOLOGIES
from vfmodel.core._text import read_text_file
from vfmodel.core.dataset import Dataset
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.io_recording import read_recording
from vfmodel.core.io_spectrum import read_spectrum
from vfmodel.errors import InputError


def read_dataset(path: str | Path, load_recordings: bool = True) -> Dataset:
    """Read a dataset directory (or its ``dataset.toml``) and every file it names."""
    p = Path(path)
    toml_path = p if p.suffix == ".toml" else p / "dataset.toml"
    root = toml_path.parent
    if not root.exists():
        raise InputError("dataset directory not found", source=str(root))
    src = str(toml_path)
    text = read_text_file(toml_path, "dataset.toml")
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"malformed TOML: {err}", source=src) from None
    name = _get(doc, "name", str, src, required=False) or root.name
    description = _get(doc, "description", str, src, required=False) or ""
    temp = _get(doc, "temperature_c", (int, float), src, required=False)
    unknown = set(doc) - {"name", "description", "temperature_c", "impedance", "recording"}
    if unknown:
        raise InputError(
            f"unknown key {sorted(unknown)[0]!r}",
            source=src,
            expected="name, description, temperature_c, [impedance], [[recording]]",
        )
    imp_table = doc.get("impedance", {})
    if not isinstance(imp_table, dict):
        raise InputError("[impedance] must be a table", source=src)
    impedance: dict[str, FrequencyData] = {}
    for topo, rel in imp_table.items():
        if topo not in TOPOLOGIES:
            raise InputError(
                "unknown topology",
                source=src,
                place="[impedance]",
                found=repr(topo),
                expected=", ".join(TOPOLOGIES),
            )
        if not isinstance(rel, str):
            raise InputError(
                "impedance file must be a string path", source=src, place=f"[impedance] {topo}"
            )
        impedance[topo] = _read_impedance(root / rel)
    recs_raw = doc.get("recording", [])
    if not isinstance(recs_raw, list):
        raise InputError("recordings must be an array of tables [[recording]]", source=src)
    recordings = []
    for k, entry in enumerate(recs_raw):
        place = f"[[recording]] #{k + 1}"
        if not isinstance(entry, dict):
            raise InputError("recording entry must be a table", source=src, place=place)
        speed = _get(entry, "speed_rpm", (int, float), src, place=place)
        rel = _get(entry, "file", str, src, place=place)
        if load_recordings:
            recordings.append(read_recording(root / rel, speed_rpm=float(speed)))
    speeds = [r.speed_rpm for r in recordings]
    if len(set(speeds)) != len(speeds):
        raise InputError("two recordings at the same speed", source=src, found=str(speeds))
    recordings.sort(key=lambda r: float(r.speed_rpm or 0.0))
    return Dataset(
        name=name,
        impedance=impedance,
        recordings=tuple(recordings),
        description=description,
        temperature_c=None if temp is None else float(temp),
        root=root,
    )


def _read_impedance(path: Path) -> FrequencyData:
    data = read_spectrum(path)
    if data.n_out != 1 or data.n_in != 1:
        raise InputError(
            "impedance spectrum must be 1-port",
            source=str(path),
            found=f"{data.n_out}x{data.n_in}",
        )
    if data.kind != "Z":
        data = data.to_kind("Z")
    return data


def _get(
    table: dict[str, Any],
    key: str,
    types: type | tuple[type, ...],
    src: str,
    place: str | None = None,
    required: bool = True,
) -> Any:
    if key not in table:
        if required:
            raise InputError(f"missing key {key!r}", source=src, place=place)
        return None
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, types):
        raise InputError(
            f"key {key!r} has the wrong type",
            source=src,
            place=place,
            found=type(value).__name__,
            expected=types.__name__ if isinstance(types, type) else " or ".join(
                t.__name__ for t in types
            ),
        )
    return value
