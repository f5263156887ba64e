"""Reading small text files with clear errors (missing, empty, binary, not UTF-8)."""

from __future__ import annotations

from pathlib import Path

from vfmodel.errors import InputError

MAX_TEXT_BYTES = 256 * 2**20
"""Largest text file read (256 MiB; checked from the file size before reading)."""
_PROBE_BYTES = 65536


def read_text_file(path: str | Path, what: str, max_bytes: int = MAX_TEXT_BYTES) -> str:
    """Return the text of ``path``; InputError naming the file for every problem.

    The size and the first 64 KiB (binary content) are checked before the whole file is
    read; a UTF-8 byte-order mark (Excel's "CSV UTF-8") is dropped.
    """
    p = Path(path)
    if not p.exists():
        raise InputError(f"{what} file not found", source=str(p))
    if not p.is_file():
        raise InputError(f"{what} path is not a file", source=str(p))
    try:
        size = p.stat().st_size
        if size > max_bytes:
            raise InputError(f"{what} file too large", source=str(p),
                             found=f"{size / 2**20:.0f} MiB",
                             expected=f"at most {max_bytes / 2**20:.0f} MiB")
        with open(p, "rb") as fh:
            head = fh.read(_PROBE_BYTES)
            if b"\x00" in head:
                raise InputError(f"{what} file is binary", source=str(p),
                                 expected="a text file")
            raw = head + fh.read()  # size checked above (read(n) would allocate n)
    except OSError as err:
        raise InputError(f"cannot read the {what} file ({err.strerror})", source=str(p)) \
            from None
    if len(raw) > max_bytes:
        raise InputError(f"{what} file too large", source=str(p),
                         expected=f"at most {max_bytes / 2**20:.0f} MiB")
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    if not raw.strip():
        raise InputError(f"{what} file is empty", source=str(p))
    if b"\x00" in raw:
        raise InputError(
            f"{what} file is binary", source=str(p), expected="a text file"
        )
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as err:
        try:
            return raw.decode("latin-1") if _mostly_printable(raw) else _raise(p, what, err)
        except UnicodeDecodeError:  # pragma: no cover - latin-1 decodes everything
            _raise(p, what, err)
    raise AssertionError("unreachable")  # pragma: no cover


def _mostly_printable(raw: bytes) -> bool:
    printable = sum(1 for b in raw if 32 <= b < 127 or b in (9, 10, 13))
    return printable >= 0.98 * len(raw)


def _raise(p: Path, what: str, err: UnicodeDecodeError) -> str:
    raise InputError(
        f"{what} file is not text",
        source=str(p),
        place=f"byte {err.start}",
        expected="UTF-8 text",
    )
