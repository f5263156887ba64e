"""Recording files: NPZ (arrays u_U, u_V, u_W, u_B and t or fs) and CSV
(header ``time_s,u_U,u_V,u_W,u_B``), CONTRACT section 2.

Either may carry the further channels of CONTRACT section 2a, ``u_B_DE`` and ``i_CM``
(NPZ: arrays of those names; CSV: columns after ``u_B``, in any order); the recording then
holds them after the four channels. Any other array or column is an error.
"""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from vfmodel.core.atomic import atomic_path, atomic_write_text
from vfmodel.core.recording import BEARING, EXTRA_CHANNELS, TERMINALS, Recording
from vfmodel.core.text import read_text_file
from vfmodel.errors import InputError

CHANNELS = (*TERMINALS, BEARING)
CSV_HEADER = ("time_s", *CHANNELS)


def _fs_from_time(t: NDArray[np.float64], src: str) -> tuple[float, float]:
    if t.ndim != 1 or t.size < 2:
        raise InputError("time axis too short", source=src, found=f"{t.size} samples")
    if not np.all(np.isfinite(t)):
        k = int(np.argmin(np.isfinite(t)))
        raise InputError("time is NaN or infinite", source=src, place=f"sample {k}")
    dt = np.diff(t)
    step = float(np.median(dt))
    if step <= 0:
        raise InputError("time axis is not increasing", source=src)
    # allow float rounding of the stored time values, nothing more
    tol = 1e-6 * step + 8 * np.finfo(float).eps * float(np.max(np.abs(t)))
    bad = np.abs(dt - step) > tol
    if np.any(bad):
        k = int(np.argmax(bad))
        raise InputError(
            "time axis is not uniformly spaced",
            source=src,
            place=f"between samples {k} and {k + 1}",
            found=f"step {dt[k]:.6g} s",
            expected=f"{step:.6g} s like the others",
        )
    fs = (t.size - 1) / float(t[-1] - t[0])
    return fs, float(t[0])


def _check_lengths(arrays: dict[str, NDArray[np.float64]], src: str) -> None:
    lengths = {k: v.size for k, v in arrays.items()}
    if len(set(lengths.values())) > 1:
        ref = max(set(lengths.values()), key=list(lengths.values()).count)
        odd = [k for k, n in lengths.items() if n != ref]
        raise InputError(
            "channels of unequal length",
            source=src,
            place=f"channel {odd[0]}",
            found=f"{lengths[odd[0]]} samples",
            expected=f"{ref} like the others",
        )


def read_recording(path: str | Path, speed_rpm: float | None = None) -> Recording:
    """Read a recording (NPZ or CSV by suffix)."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix == ".npz":
        return _read_npz(p, speed_rpm)
    if suffix == ".csv":
        return _read_csv(p, speed_rpm)
    raise InputError(
        "unknown recording file type", source=str(p), found=repr(p.suffix),
        expected="'.npz' or '.csv'",
    )


MAX_SAMPLES = 2**26
"""Longest recording accepted: 67 million samples per channel (checked from the array
headers before anything is allocated)."""
EXTRA_ARRAYS = EXTRA_CHANNELS
"""Further channels a recording may hold (CONTRACT section 2a), carried after the four."""
KNOWN_ARRAYS = (*CHANNELS, "t", "fs", *EXTRA_ARRAYS)


def _npz_headers(p: Path, src: str) -> None:
    """Check every array header of an NPZ before loading: names, dtypes and sizes.

    An array larger than :data:`MAX_SAMPLES` or than the bytes its member holds (a
    corrupt or forged header) is refused without allocating it.
    """
    from numpy.lib import format as npf

    try:
        with zipfile.ZipFile(p) as zf:
            for info in zf.infolist():
                name = info.filename.removesuffix(".npy")
                if name not in KNOWN_ARRAYS:
                    raise InputError("unknown array", source=src, place=f"array {name[:40]}",
                                     expected=", ".join(KNOWN_ARRAYS))
                with zf.open(info) as fh:
                    version = npf.read_magic(fh)
                    if version == (1, 0):
                        shape, _, dtype = npf.read_array_header_1_0(fh)
                    else:
                        shape, _, dtype = npf.read_array_header_2_0(fh)
                    header_len = fh.tell()
                if dtype.hasobject or dtype.itemsize == 0:
                    raise InputError("array of objects", source=src, place=f"array {name}",
                                     expected="numbers")
                count = int(np.prod(shape, dtype=object))
                if count > MAX_SAMPLES:
                    raise InputError("array too large", source=src, place=f"array {name}",
                                     found=f"{count} values",
                                     expected=f"at most {MAX_SAMPLES} samples per channel")
                if count * dtype.itemsize > info.file_size - header_len:
                    raise InputError("array header declares more data than the file holds",
                                     source=src, place=f"array {name}",
                                     found=f"{count} values in {info.file_size} bytes")
    except InputError:
        raise
    except (OSError, ValueError, zipfile.BadZipFile, EOFError, KeyError) as err:
        raise InputError(f"not a readable NPZ file ({type(err).__name__})", source=src) \
            from None


def _read_npz(p: Path, speed_rpm: float | None) -> Recording:
    src = str(p)
    if not p.is_file():
        raise InputError("recording file not found", source=src)
    _npz_headers(p, src)
    try:
        with np.load(p, allow_pickle=False) as z:
            arrays = {k: np.asarray(z[k]) for k in z.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as err:
        raise InputError(f"not a readable NPZ file ({type(err).__name__})", source=src) \
            from None
    missing = [c for c in CHANNELS if c not in arrays]
    if missing:
        raise InputError(
            f"missing array {missing[0]}",
            source=src,
            found=", ".join(sorted(arrays)) or "no arrays",
            expected="u_U, u_V, u_W, u_B and t or fs",
        )
    chans: dict[str, NDArray[np.float64]] = {}
    names = (*CHANNELS, *(c for c in EXTRA_ARRAYS if c in arrays))
    for c in names:
        a = arrays[c]
        if a.ndim != 1 or not np.issubdtype(a.dtype, np.number) or np.iscomplexobj(a):
            raise InputError(
                "channel must be a 1-D real array", source=src, place=f"array {c}",
                found=f"shape {a.shape}, dtype {a.dtype}",
            )
        chans[c] = a.astype(float)
    _check_lengths(chans, src)
    for key in ("t", "fs"):
        if key in arrays and (np.iscomplexobj(arrays[key])
                              or not np.issubdtype(arrays[key].dtype, np.number)
                              or arrays[key].dtype == np.bool_):
            raise InputError("time data must be real numbers", source=src,
                             place=f"array {key}", found=f"dtype {arrays[key].dtype}",
                             expected="a real (float or integer) array")
    fs_given = None
    if "fs" in arrays:
        fsa = np.asarray(arrays["fs"])
        if fsa.size != 1:
            raise InputError("fs must be a scalar", source=src, place="array fs",
                             found=f"shape {fsa.shape}")
        fs_given = float(fsa.ravel()[0])
        if not (np.isfinite(fs_given) and fs_given > 0):
            raise InputError("sample rate must be a positive finite number", source=src,
                             place="array fs", found=f"{fs_given:g}")
    if "t" in arrays:
        t = np.asarray(arrays["t"], dtype=float)
        if t.size != chans[CHANNELS[0]].size:
            raise InputError(
                "time axis and channels of unequal length", source=src, place="array t",
                found=f"{t.size} samples", expected=f"{chans[CHANNELS[0]].size}",
            )
        fs, t0 = _fs_from_time(t, src)
        if fs_given is not None and abs(fs_given - fs) > 1e-6 * fs:
            raise InputError("t and fs disagree", source=src, place="arrays t and fs",
                             found=f"fs {fs_given:.9g} Hz, t spaced for {fs:.9g} Hz",
                             expected="one of them, or both consistent")
    elif fs_given is not None:
        fs, t0 = fs_given, 0.0
    else:
        raise InputError("no time axis", source=src, expected="an array t or a scalar fs")
    return Recording(fs, np.stack([chans[c] for c in names]), names, speed_rpm, t0, src)


def _read_csv(p: Path, speed_rpm: float | None) -> Recording:
    src = str(p)
    text = read_text_file(p, "recording CSV")
    first, _, rest = text.partition("\n")
    header = tuple(c.strip() for c in first.strip().split(","))
    extras = header[len(CSV_HEADER):]
    if header[:len(CSV_HEADER)] != CSV_HEADER or len(set(extras)) != len(extras) \
            or not set(extras) <= set(EXTRA_ARRAYS):
        raise InputError(
            "unknown recording CSV header", source=src, place="line 1",
            found=first.strip()[:80],
            expected=",".join(CSV_HEADER) + " then optionally " + " and ".join(EXTRA_ARRAYS),
        )
    if not rest.strip():
        raise InputError("recording CSV has no data rows", source=src)
    try:
        table = np.loadtxt(io.StringIO(rest), delimiter=",", ndmin=2)
    except ValueError as err:
        raise InputError(f"unreadable data: {err}", source=src) from None
    if table.size == 0:
        raise InputError("recording CSV has no data rows", source=src)
    if table.shape[1] != len(header):
        raise InputError(
            "wrong number of columns", source=src, found=str(table.shape[1]),
            expected=str(len(header)),
        )
    for c, name in enumerate(header):
        bad = ~np.isfinite(table[:, c])
        if bad.any():
            raise InputError(
                "NaN or infinite sample", source=src,
                place=f"line {int(np.argmax(bad)) + 2}, column {name}", expected="finite numbers",
            )
    fs, t0 = _fs_from_time(table[:, 0], src)
    # the four channels first, then the further ones in file order
    names = (*CHANNELS, *extras)
    return Recording(fs, table[:, 1:].T, names, speed_rpm, t0, src)


def write_recording(path: str | Path, rec: Recording) -> None:
    """Write a recording as NPZ (``fs`` scalar) or CSV, by suffix, atomically."""
    p = Path(path)
    if p.suffix.lower() == ".npz":
        arrays = {c: rec.channel(c) for c in rec.channels}
        with atomic_path(p) as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(fh, fs=np.float64(rec.fs), **arrays)  # type: ignore[arg-type]
        return
    if p.suffix.lower() == ".csv":
        missing = [c for c in CHANNELS if c not in rec.channels]
        if missing:
            raise InputError("recording lacks channels for CSV", found=str(missing))
        buf = io.StringIO()
        cols = (*CHANNELS, *rec.extra_channels)
        table = np.column_stack([rec.t, *(rec.channel(c) for c in cols)])
        np.savetxt(buf, table, delimiter=",", header=",".join(("time_s", *cols)), comments="",
                   fmt="%.12g")
        atomic_write_text(p, buf.getvalue())
        return
    raise InputError("unknown recording file type", source=str(p), expected="'.npz' or '.csv'")
