"""Reading small text files with clear errors (missing, empty, binary, not UTF-8)."""

from __future__ import annotations

from pathlib import Path

from vfmodel.errors import InputError


def read_text_file(path: str | Path, what: str) -> str:
    """Return the text of ``path``; InputError naming the file for every problem."""
    p = Path(path)
    if not p.exists():
        raise InputError(f"{what} file not found", source=str(p))
    if not p.is_file():
        raise InputError(f"{what} path is not a file", source=str(p))
    raw = p.read_bytes()
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
