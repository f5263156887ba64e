"""Spectrum files: Touchstone (any port count, via scikit-rf) and CSV.

CSV column sets (header row, comma separated, SI units):

* 1-port impedance (CONTRACT section 2): ``frequency_hz,z_real_ohm,z_imag_ohm`` or
  ``frequency_hz,z_mag_ohm,z_phase_deg``.
* Any kind and port count (vfmodel extension): ``frequency_hz`` followed by
  ``<k><i>_<j>_real,<k><i>_<j>_imag`` for every entry, ``k`` in ``z y s h``, 1-based
  ``i`` (output) and ``j`` (input), row-major. An optional first line
  ``# z0_ohm=50`` gives the reference impedance of S data.
"""

from __future__ import annotations

import csv
import io
import os
import re
import warnings
from pathlib import Path

import numpy as np

from vfmodel._choices import Kind
from vfmodel.core.atomic import atomic_write_text
from vfmodel.core.frequency_data import FrequencyData
from vfmodel.core.text import read_text_file
from vfmodel.errors import InputError

_TOUCHSTONE_RE = re.compile(r"^\.(s(\d+)p|ts)$", re.IGNORECASE)
_Z_RI = ("frequency_hz", "z_real_ohm", "z_imag_ohm")
_Z_MP = ("frequency_hz", "z_mag_ohm", "z_phase_deg")
MAX_PORTS = 256
"""Most ports (or CSV matrix rows/columns) a spectrum file may declare."""
_GENERIC_RE = re.compile(r"^([zysh])(\d+)_(\d+)_(real|imag)$")


def spectrum_format(path: str | os.PathLike[str]) -> str:
    """'touchstone' or 'csv' from the file suffix; InputError otherwise."""
    suffix = Path(path).suffix
    if suffix.lower() == ".csv":
        return "csv"
    if _TOUCHSTONE_RE.match(suffix):
        return "touchstone"
    raise InputError(
        "unknown spectrum file type",
        source=str(path),
        found=f"suffix {suffix!r}",
        expected="'.csv', '.sNp' (Touchstone, N ports) or '.ts'",
    )


def read_spectrum(path: str | os.PathLike[str]) -> FrequencyData:
    """Read a Touchstone or CSV spectrum (format from the suffix).

    Touchstone files keep their parameter type (S, Z or Y) and reference impedance;
    the file is parsed by scikit-rf.
    """
    fmt = spectrum_format(path)
    return _read_touchstone(Path(path)) if fmt == "touchstone" else _read_csv(Path(path))


def write_spectrum(path: str | Path, data: FrequencyData) -> None:
    """Write ``data`` as Touchstone or CSV (format from the suffix), atomically."""
    fmt = spectrum_format(path)
    text = _touchstone_text(Path(path), data) if fmt == "touchstone" else csv_text(data)
    atomic_write_text(path, text)


# ---------------------------------------------------------------------- Touchstone
def _read_touchstone(path: Path) -> FrequencyData:
    """Touchstone file: see :mod:`vfmodel.core.io_touchstone` (own v1 parser, Y/Z
    normalisation by R, fields of the option line in any order)."""
    from vfmodel.core.io_touchstone import ports_from_suffix, read_touchstone_text

    src = str(path)
    n = ports_from_suffix(path)
    if n is not None and not 1 <= n <= MAX_PORTS:
        raise InputError("unsupported port count in the file suffix", source=src,
                         found=path.suffix, expected=f"1 to {MAX_PORTS} ports")
    return read_touchstone_text(read_text_file(path, "Touchstone"), n, src)


def _touchstone_text(path: Path, data: FrequencyData) -> str:
    if data.kind == "H":
        raise InputError(
            "transfer-function (H) data cannot be written as Touchstone",
            source=str(path),
            expected="a '.csv' output for H data",
        )
    m = _TOUCHSTONE_RE.match(path.suffix)
    assert m is not None
    if m.group(2) is not None and int(m.group(2)) != data.n_out:
        raise InputError(
            "output suffix does not match the port count",
            source=str(path),
            found=f"{data.n_out}-port data",
            expected=f".s{data.n_out}p",
        )
    z0 = data.z0 if data.kind == "S" and data.z0 is not None else 50.0
    if data.kind != "S":
        # scikit-rf would recompute Z/Y through S; write the caller's values exactly
        return _touchstone_rows(data, z0)
    net = data.to_network(z0=z0)
    net.name = path.stem
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        text = net.write_touchstone(
            return_string=True,
            form="ri",
            parameter=data.kind,
            r_ref=z0,
            format_spec_A="{:.17g}",
            format_spec_B="{:.17g}",
            format_spec_freq="{:.17g}",
            skrf_comment=False,
        )
    assert isinstance(text, str)
    return text


def _touchstone_rows(data: FrequencyData, z0: float) -> str:
    """Touchstone 1.1 text for Z or Y data (values normalised by R, RI format, Hz)."""
    n = data.n_out
    norm = z0 if data.kind == "Z" else 1.0 / z0
    lines = ["! written by vfmodel", f"# Hz {data.kind} RI R {z0:.17g}"]
    for f, v in zip(data.freq_hz, data.values / norm, strict=True):
        # Touchstone 1: 2-port data are column-major (N11 N21 N12 N22), others row-major
        entries = v.T.ravel() if n == 2 else v.ravel()
        nums = [f"{x:.17g}" for e in entries for x in (e.real, e.imag)]
        per_line = 8 if n <= 2 else min(8, 2 * n)
        first = [f"{f:.17g}", *nums[:per_line]]
        lines.append(" ".join(first))
        for k in range(per_line, len(nums), per_line):
            lines.append(" ".join(nums[k : k + per_line]))
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------- CSV
def csv_text(data: FrequencyData) -> str:
    """CSV text of ``data`` (contract column set for 1-port Z, generic otherwise)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    n_out, n_in = data.n_out, data.n_in
    flat = data.values.reshape(data.n_freq, -1)
    if data.kind == "Z" and n_out == n_in == 1:
        w.writerow(_Z_RI)
    else:
        if data.kind == "S":
            buf.write(f"# z0_ohm={data.z0:.17g}\n")
        k = data.kind.lower()
        header = ["frequency_hz"]
        for i in range(n_out):
            for j in range(n_in):
                header += [f"{k}{i + 1}_{j + 1}_real", f"{k}{i + 1}_{j + 1}_imag"]
        w.writerow(header)
    for f, row in zip(data.freq_hz, flat, strict=True):
        cells = [f"{f:.17g}"]
        for x in row:
            cells += [f"{x.real:.17g}", f"{x.imag:.17g}"]
        w.writerow(cells)
    return buf.getvalue()


def _read_csv(path: Path) -> FrequencyData:
    src = str(path)
    text = read_text_file(path, "CSV")
    lines = text.splitlines()
    z0: float | None = None
    start = 0
    while start < len(lines) and lines[start].lstrip().startswith("#"):
        m = re.match(r"#\s*z0_ohm\s*=\s*(\S+)", lines[start].strip())
        if m:
            try:
                z0 = float(m.group(1))
            except ValueError:
                raise InputError(
                    "bad z0_ohm comment", source=src, place="line 1", found=m.group(1)
                ) from None
        start += 1
    rows = list(csv.reader(lines[start:]))
    if not rows:
        raise InputError("CSV file has no header", source=src)
    header = tuple(c.strip() for c in rows[0])
    body = [(start + k + 2, r) for k, r in enumerate(rows[1:]) if any(c.strip() for c in r)]
    if not body:
        raise InputError("CSV file has a header but no data rows", source=src)
    table = _numeric_table(body, len(header), src)
    f = table[:, 0]
    if header == _Z_RI:
        values = table[:, 1] + 1j * table[:, 2]
        kind: Kind = "Z"
    elif header == _Z_MP:
        mag, phase = table[:, 1], table[:, 2]
        if np.any(mag < 0):
            k = int(np.argmax(mag < 0))
            raise InputError(
                "negative impedance magnitude",
                source=src,
                place=f"line {body[k][0]}, column z_mag_ohm",
                found=f"{mag[k]:g}",
                expected="|Z| >= 0",
            )
        values = mag * np.exp(1j * np.deg2rad(phase))
        kind = "Z"
    else:
        values, kind = _generic_columns(header, table, src)
    return FrequencyData(f, values, kind=kind, z0=z0 if kind == "S" else None, source=src)


def _numeric_table(body: list[tuple[int, list[str]]], n_cols: int, src: str) -> np.ndarray:
    out = np.empty((len(body), n_cols))
    for k, (line_no, row) in enumerate(body):
        if len(row) != n_cols:
            raise InputError(
                "wrong number of fields",
                source=src,
                place=f"line {line_no}",
                found=str(len(row)),
                expected=f"{n_cols} as in the header",
            )
        for c, cell in enumerate(row):
            try:
                out[k, c] = float(cell)
            except ValueError:
                raise InputError(
                    "not a number",
                    source=src,
                    place=f"line {line_no}, column {c + 1}",
                    found=repr(cell.strip()[:40]),
                ) from None
            if not np.isfinite(out[k, c]):
                raise InputError(
                    "value is NaN or infinite",
                    source=src,
                    place=f"line {line_no}, column {c + 1}",
                    found=cell.strip(),
                    expected="a finite number",
                )
    return out


def _generic_columns(
    header: tuple[str, ...], table: np.ndarray, src: str
) -> tuple[np.ndarray, Kind]:
    expected = (
        f"'{','.join(_Z_RI)}', '{','.join(_Z_MP)}' or 'frequency_hz' followed by "
        "<k><i>_<j>_real,<k><i>_<j>_imag columns"
    )
    if len(header) < 3 or header[0] != "frequency_hz" or len(header) % 2 != 1:
        raise InputError(
            "unknown CSV column set", source=src, found=",".join(header)[:120], expected=expected
        )
    parsed = [_GENERIC_RE.match(h.lower()) for h in header[1:]]
    if not all(parsed):
        raise InputError(
            "unknown CSV column set", source=src, found=",".join(header)[:120], expected=expected
        )
    matches = [m for m in parsed if m is not None]
    kinds = {m.group(1) for m in matches}
    if len(kinds) != 1:
        raise InputError("CSV columns mix parameter kinds", source=src, found=str(sorted(kinds)))
    n_out = max(int(m.group(2)) for m in matches)
    n_in = max(int(m.group(3)) for m in matches)
    if 2 * n_out * n_in != len(matches):  # checked before allocating (n_freq, n_out, n_in)
        raise InputError(
            "CSV columns do not cover every entry",
            source=src,
            found=f"{len(matches)} value columns for indices up to {n_out}x{n_in}",
            expected=f"{2 * n_out * n_in} columns (real and imag of every entry)",
        )
    values = np.zeros((table.shape[0], n_out, n_in), complex)
    seen: set[tuple[int, int, str]] = set()
    for col, m in enumerate(matches, start=1):
        i, j, part = int(m.group(2)) - 1, int(m.group(3)) - 1, m.group(4)
        if i < 0 or j < 0 or (i, j, part) in seen:
            raise InputError("duplicate or zero index column", source=src, found=header[col])
        seen.add((i, j, part))
        values[:, i, j] += table[:, col] * (1j if part == "imag" else 1.0)
    if len(seen) != 2 * n_out * n_in:
        raise InputError(
            "CSV columns do not cover every entry",
            source=src,
            found=f"{len(seen) // 2} of {n_out}x{n_in} entries",
        )
    kind_map: dict[str, Kind] = {"z": "Z", "y": "Y", "s": "S", "h": "H"}
    return values, kind_map[kinds.pop()]
