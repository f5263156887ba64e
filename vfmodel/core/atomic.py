"""Atomic file output: write to a temporary file beside the target, then rename.

A crash or an error while writing never leaves a partial file that looks complete.
:func:`staged_output` does the same for the whole output set of a command: every file is
written into a hidden staging folder and the set is swapped in at the end, replacing the
outputs of an earlier run (listed in ``.vfmodel-outputs``), so a folder never holds a mix
of two runs or a partial set. Files are created with the modes the user's umask allows.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any


def umask() -> int:
    """The process umask (read without changing it for longer than two calls)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _chmod_default(path: Path, directory: bool = False) -> None:
    """Give a ``mkstemp``/``mkdtemp`` result (0600/0700) the mode a plain create would."""
    base = 0o777 if directory else 0o666
    with contextlib.suppress(OSError):
        path.chmod(base & ~umask())


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path in the target's directory; rename it to ``path`` on success."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    _chmod_default(tmp_path)
    try:
        yield tmp_path
        os.replace(tmp_path, target)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


@contextlib.contextmanager
def atomic_directory(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary directory beside ``path``; on success it replaces ``path``.

    On an error the temporary directory is removed and ``path`` is left as it was.
    """
    import shutil

    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=target.name + ".", dir=target.parent))
    _chmod_default(tmp, directory=True)
    try:
        yield tmp
        if target.exists():
            shutil.rmtree(target)
        tmp.rename(target)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


# ---------------------------------------------------------------- staged command outputs
MANIFEST = ".vfmodel-outputs"
"""File in an output folder listing the outputs of the run that wrote it (one a line)."""


def _nearest_existing(path: Path) -> Path:
    p = path
    while not os.path.lexists(p) and p != p.parent:
        p = p.parent
    return p


def _place_error(message: str, shown: str, option: str, found: str | None = None) -> Exception:
    from vfmodel.errors import InputError

    return InputError(message, source=shown, place=option, found=found)


def check_output_place(path: str | os.PathLike[str], option: str, *, directory: bool) -> Path:
    """Check that ``path`` (given as ``option``) can be created or replaced; return the
    existing folder in which its temporary files go. InputError naming ``path`` otherwise."""
    target = Path(path)
    shown = str(path)
    if os.path.lexists(target):
        if directory and not target.is_dir():
            raise _place_error("output folder is a file", shown, option,
                               _what_is(target))
        if not directory and target.is_dir():
            raise _place_error("output file is a folder", shown, option, "a directory")
    anchor = target if (directory and target.is_dir()) else _nearest_existing(target.parent)
    if not anchor.is_dir():
        raise _place_error("cannot create the output: a path component is a file", shown,
                           option, f"{anchor} is not a directory")
    if not os.access(anchor, os.W_OK | os.X_OK):
        raise _place_error("output place is not writable", shown, option,
                           f"no write permission in {anchor}")
    try:  # the permission bits do not tell everything (root, read-only or special mounts)
        fd, probe = tempfile.mkstemp(prefix=".vfmodel-probe-", dir=anchor)
        os.close(fd)
        os.unlink(probe)
    except OSError as err:
        raise _place_error("output place is not writable", shown, option,
                           err.strerror or type(err).__name__) from None
    return anchor


def _what_is(target: Path) -> str:
    return "a regular file" if target.is_file() else "not a directory"


def _mkdtemp(anchor: Path, shown: str, option: str) -> Path:
    try:
        tmp = Path(tempfile.mkdtemp(prefix=".vfmodel-stage-", dir=anchor))
    except OSError as err:
        raise _place_error("output place is not writable", shown, option,
                           err.strerror or type(err).__name__) from None
    _chmod_default(tmp, directory=True)
    return tmp


class Stage:
    """The staging folder of one command run (see :func:`staged_output`)."""

    def __init__(self, out_dir: Path, option: str, owned: tuple[str, ...]) -> None:
        self.out_dir = out_dir
        self._existed = out_dir.is_dir()
        anchor = check_output_place(out_dir, option, directory=True)
        self.dir = _mkdtemp(anchor, str(out_dir), option)
        self._owned = owned
        self._extras: list[tuple[Path, Path]] = []

    def path(self, name: str) -> Path:
        """Where to write output ``name`` of the folder (a plain file name)."""
        return self.dir / name

    def extra(self, target: str | os.PathLike[str], option: str) -> Path:
        """A staged file for an output outside the folder (e.g. ``--spice FILE``)."""
        t = Path(target)
        anchor = check_output_place(t, option, directory=False)
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{t.name}.", suffix=".tmp", dir=anchor)
        except OSError as err:
            raise _place_error("output place is not writable", str(target), option,
                               err.strerror or type(err).__name__) from None
        os.close(fd)
        tmp_path = Path(tmp)
        _chmod_default(tmp_path)
        self._extras.append((tmp_path, t))
        return tmp_path

    def _old_outputs(self) -> set[str]:
        import fnmatch

        names = {q.name for q in self.out_dir.iterdir() if q.is_file()
                 and any(fnmatch.fnmatchcase(q.name, pat) for pat in self._owned)}
        manifest = self.out_dir / MANIFEST
        if manifest.is_file():
            with contextlib.suppress(OSError, UnicodeDecodeError):
                for line in manifest.read_text(encoding="utf-8").splitlines():
                    n = line.strip()
                    if n and "/" not in n and "\\" not in n and n not in (".", ".."):
                        names.add(n)
        return names

    def commit(self) -> None:
        """Swap the staged outputs in (removing an earlier run's outputs)."""
        new = sorted(p.name for p in self.dir.iterdir() if not p.name.startswith(".vfmodel"))
        (self.dir / MANIFEST).write_text("".join(n + "\n" for n in new), encoding="utf-8")
        if not self._existed and not os.path.lexists(self.out_dir):
            self.out_dir.parent.mkdir(parents=True, exist_ok=True)
            os.rename(self.dir, self.out_dir)
        else:
            for name in sorted(self._old_outputs() - set(new)):
                with contextlib.suppress(FileNotFoundError, IsADirectoryError):
                    (self.out_dir / name).unlink()
            for name in [*new, MANIFEST]:
                os.replace(self.dir / name, self.out_dir / name)
        for tmp, target in self._extras:
            target.parent.mkdir(parents=True, exist_ok=True)
            os.replace(tmp, target)
        self._extras = []

    def discard(self) -> None:
        """Remove whatever is left of the staging (after a commit: nothing)."""
        import shutil

        if self.dir.exists() and self.dir != self.out_dir:
            shutil.rmtree(self.dir, ignore_errors=True)
        for tmp, _ in self._extras:
            with contextlib.suppress(OSError):
                tmp.unlink()


@contextlib.contextmanager
def staged_output(
    out_dir: str | os.PathLike[str], *, option: str = "--out", owned: tuple[str, ...] = ()
) -> Iterator[Stage]:
    """Stage a command's outputs and swap them into ``out_dir`` together on success.

    The place is checked when the context opens (InputError naming ``out_dir`` and
    ``option``: a file in the way, no write permission), so a command opens it before any
    long computation. On an error or an interrupt nothing of the run is left, and an
    earlier run's outputs stay as they were; on success the outputs listed in the
    folder's ``.vfmodel-outputs`` (and the ``owned`` names) that this run did not write
    are removed, so the folder holds exactly one run's outputs beside the user's own files.
    ``owned`` holds file names or ``fnmatch`` patterns (for folders written before the
    manifest existed).
    """
    stage = Stage(Path(out_dir), option, owned)
    try:
        yield stage
        stage.commit()
    finally:
        stage.discard()


def finite_json(obj: Any) -> Any:
    """``obj`` with every non-finite float (inf, -inf, NaN) replaced by ``None``.

    Strict JSON has no infinity or NaN; vfmodel writes ``null`` for such a number (README,
    "Output files": an unbounded significance, a band reaching infinity, a value that
    could not be computed).
    """
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite_json(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [finite_json(v) for v in obj]
    if hasattr(obj, "dtype") and hasattr(obj, "tolist"):  # numpy scalar or array
        return finite_json(obj.tolist())
    return obj


def write_json(path: Path, obj: Any) -> None:
    """Write ``obj`` as indented strict JSON (non-finite numbers as null), atomically."""
    atomic_write_text(path, json.dumps(finite_json(obj), indent=2, allow_nan=False) + "\n")
