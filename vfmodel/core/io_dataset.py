"""Reading a dataset directory (``dataset.toml``, CONTRACT sections 2 and 2a).

Besides the paper's spectra and recordings, ``dataset.toml`` may name the further
measurements of section 2a (``"Shaft-Frame"`` in ``[impedance]``, ``[[impedance_at_speed]]``
entries) and hold the optional ``[machine]``, ``[bearing]`` and ``[priors]`` tables
(:mod:`vfmodel.core.io_machine`; documented in docs/dataset-priors.md).
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

from vfmodel._choices import ALL_TOPOLOGIES, TOPOLOGIES
from vfmodel.core.dataset import Dataset, SpeedImpedance
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.io_machine import parse_bearing, parse_machine, parse_priors
from vfmodel.core.io_recording import read_recording
from vfmodel.core.io_spectrum import read_spectrum
from vfmodel.core.text import read_text_file
from vfmodel.errors import InputError

RECORDING_KEYS = ("speed_rpm", "file")
AT_SPEED_KEYS = ("topology", "speed_rpm", "file")
TOP_KEYS = ("name", "description", "temperature_c", "impedance", "recording",
            "impedance_at_speed", "machine", "bearing", "priors")


def dataset_file(root: Path, rel: object, source: str, place: str,
                 allow_outside: bool = False) -> Path:
    """The file ``rel`` names, relative to the dataset folder ``root``.

    A dataset may only reach files inside its own folder: an absolute path, a ``..`` that
    leaves the folder or a symbolic link that points out of it is refused (InputError
    naming ``source`` and ``place``, never quoting the file) unless ``allow_outside``.
    """
    if not isinstance(rel, str) or not rel.strip():
        raise InputError("file must be a non-empty string path", source=source, place=place)
    if "\x00" in rel:
        raise InputError("file path holds a NUL character", source=source, place=place)
    target = root / rel
    if allow_outside:
        return target
    if Path(rel).is_absolute():
        raise InputError("absolute path: a dataset may only reference files inside its "
                         "folder", source=source, place=place, found=repr(rel),
                         expected="a path relative to the dataset folder")
    try:
        inside = target.resolve().is_relative_to(root.resolve())
    except (OSError, RuntimeError):  # a symlink loop
        inside = False
    if not inside:
        raise InputError("path leads outside the dataset folder", source=source, place=place,
                         found=repr(rel), expected="a file inside the dataset folder (no "
                         "'..' out of it, no symbolic link pointing out of it)")
    return target


def _finite(value: float, key: str, src: str, place: str | None) -> float:
    x = float(value)
    if not math.isfinite(x):
        raise InputError(f"key {key!r} is not a finite number", source=src, place=place,
                         found=str(value), expected="a finite number")
    return x


def read_dataset(path: str | Path, load_recordings: bool = True,
                 allow_outside: bool = False) -> Dataset:
    """Read a dataset directory (or its ``dataset.toml``) and every file it names.

    Files are resolved relative to the dataset folder and must lie inside it (see
    :func:`dataset_file`); ``allow_outside=True`` lifts that rule for trusted datasets.
    """
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
    if temp is not None:
        temp = _finite(temp, "temperature_c", src, None)
    unknown = set(doc) - set(TOP_KEYS)
    if unknown:
        raise InputError(
            f"unknown key {sorted(unknown)[0]!r}",
            source=src,
            expected="name, description, temperature_c, [impedance], [[recording]], "
                     "[[impedance_at_speed]], [machine], [bearing], [priors]",
        )
    machine = parse_machine(doc, src)
    bearing = parse_bearing(doc, src)
    overrides = parse_priors(doc, src)
    imp_table = doc.get("impedance", {})
    if not isinstance(imp_table, dict):
        raise InputError("[impedance] must be a table", source=src)
    impedance: dict[str, FrequencyData] = {}
    further: dict[str, FrequencyData] = {}
    for topo, rel in imp_table.items():
        if topo not in ALL_TOPOLOGIES:
            raise InputError(
                "unknown topology",
                source=src,
                place="[impedance]",
                found=repr(topo),
                expected=", ".join(ALL_TOPOLOGIES),
            )
        if not isinstance(rel, str):
            raise InputError(
                "impedance file must be a string path", source=src, place=f"[impedance] {topo}"
            )
        # the paper's six apart from the further ones (section 2a): code that iterates
        # over Dataset.impedance sees only the six
        (impedance if topo in TOPOLOGIES else further)[topo] = _read_impedance(
            dataset_file(root, rel, src, f"[impedance] {topo}", allow_outside))
    at_speed = _read_at_speed(doc, root, src, allow_outside)
    recs_raw = doc.get("recording", [])
    if not isinstance(recs_raw, list):
        raise InputError("recordings must be an array of tables [[recording]]", source=src)
    recordings = []
    for k, entry in enumerate(recs_raw):
        place = f"[[recording]] #{k + 1}"
        if not isinstance(entry, dict):
            raise InputError("recording entry must be a table", source=src, place=place)
        unknown_keys = sorted(set(entry) - set(RECORDING_KEYS))
        if unknown_keys:
            raise InputError(f"unknown key {unknown_keys[0]!r}", source=src, place=place,
                             expected=", ".join(RECORDING_KEYS))
        speed = _finite(_get(entry, "speed_rpm", (int, float), src, place=place),
                        "speed_rpm", src, place)
        rel = _get(entry, "file", str, src, place=place)
        path_k = dataset_file(root, rel, src, f"{place} file", allow_outside)
        if load_recordings:
            recordings.append(read_recording(path_k, speed_rpm=speed))
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
        further_impedance=further,
        impedance_at_speed=at_speed,
        machine=machine,
        bearing=bearing,
        prior_overrides=overrides,
    )


def _read_at_speed(doc: dict[str, Any], root: Path, src: str,
                   allow_outside: bool) -> tuple[SpeedImpedance, ...]:
    """The ``[[impedance_at_speed]]`` entries (topology, speed_rpm > 0, file)."""
    raw = doc.get("impedance_at_speed", [])
    if not isinstance(raw, list):
        raise InputError("impedance at speed must be an array of tables "
                         "[[impedance_at_speed]]", source=src)
    out: list[SpeedImpedance] = []
    for k, entry in enumerate(raw):
        place = f"[[impedance_at_speed]] #{k + 1}"
        if not isinstance(entry, dict):
            raise InputError("impedance_at_speed entry must be a table", source=src,
                             place=place)
        unknown_keys = sorted(set(entry) - set(AT_SPEED_KEYS))
        if unknown_keys:
            raise InputError(f"unknown key {unknown_keys[0]!r}", source=src, place=place,
                             expected=", ".join(AT_SPEED_KEYS))
        topo = _get(entry, "topology", str, src, place=place)
        if topo not in ALL_TOPOLOGIES:
            raise InputError("unknown topology", source=src, place=f"{place} topology",
                             found=repr(topo), expected=", ".join(ALL_TOPOLOGIES))
        speed = _finite(_get(entry, "speed_rpm", (int, float), src, place=place),
                        "speed_rpm", src, place)
        if not speed > 0:
            raise InputError("speed_rpm of an impedance at speed must be > 0 (standstill "
                             "spectra belong in [impedance])", source=src,
                             place=f"{place} speed_rpm", found=f"{speed:g}")
        if any(s.topology == topo and s.speed_rpm == speed for s in out):
            raise InputError(f"two {topo} spectra at {speed:g} rpm", source=src, place=place)
        rel = _get(entry, "file", str, src, place=place)
        data = _read_impedance(dataset_file(root, rel, src, f"{place} file", allow_outside))
        out.append(SpeedImpedance(topo, speed, data))
    return tuple(sorted(out, key=lambda s: (s.topology, s.speed_rpm)))


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
