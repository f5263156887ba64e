"""Harness of the adversarial suite (tests/test_adversarial_*.py, issue 16).

Every case runs the CLI in-process (``vfmodel.cli.main.main``) inside its own folder and
asserts what CONTRACT section 2 promises for bad input: exit status 2, exactly one line on
stderr naming the file or place the user gave, no traceback, no output left (the whole
case folder is unchanged: inputs intact, no output folder, no staging or temporary file),
and a bounded peak of Python/numpy memory (tracemalloc).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tracemalloc
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from vfmodel.cli.main import main

MAX_PEAK_MB = 200.0
"""Peak traced allocation allowed for one refused case (the bad inputs are small or lie
about their size: nothing large may be allocated)."""


@dataclass(frozen=True)
class Outcome:
    code: int
    out: str
    err: str
    peak_mb: float


def run_cli(capsys: pytest.CaptureFixture[str], argv: list[str]) -> Outcome:
    """Run ``vfmodel argv`` in-process; exit status, stdout, stderr, peak traced MiB."""
    capsys.readouterr()
    tracemalloc.start()
    try:
        code = main(argv)
    finally:
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    cap = capsys.readouterr()
    return Outcome(code, cap.out, cap.err, peak / 2**20)


def snapshot(root: Path) -> dict[str, str]:
    """Every entry below ``root`` (not following links): kind, mode and content hash."""
    out: dict[str, str] = {}
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            st = p.lstat()
            rel = str(p.relative_to(root))
            if p.is_symlink():
                out[rel] = "link:" + os.readlink(p)
            elif p.is_dir():
                out[rel] = f"dir:{st.st_mode:o}"
            else:
                out[rel] = f"file:{st.st_mode:o}:" + hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def assert_refused(res: Outcome, names: str | tuple[str, ...], before: dict[str, str],
                   root: Path, *, code: int = 2, one_line: bool = True,
                   secret: str | None = None) -> None:
    """The contract for bad input (see the module docstring)."""
    text = res.out + res.err
    assert res.code == code, text
    assert "Traceback" not in text, text
    lines = [ln for ln in res.err.splitlines() if ln.strip()]
    if one_line:
        assert len(lines) == 1, res.err
        assert lines[0].startswith("vfmodel: error:"), res.err
        wanted = (names,) if isinstance(names, str) else names
        assert any(n in lines[0] for n in wanted), (wanted, res.err)
    if secret is not None:
        assert secret not in text, text
    after = snapshot(root)
    assert after == before, {k: (before.get(k), after.get(k))
                             for k in set(before) | set(after) if before.get(k) != after.get(k)}
    assert res.peak_mb < MAX_PEAK_MB, f"peak {res.peak_mb:.0f} MiB"


def copy_tree(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst, symlinks=True)
    return dst


# ---------------------------------------------------------------- small valid inputs
def z_csv(n: int = 31) -> str:
    f = np.logspace(3, 7, n)
    z = 5 + 2j * np.pi * f * 1e-6 + 1 / (2j * np.pi * f * 1e-9)
    rows = "\n".join(f"{a:.12g},{b.real:.12g},{b.imag:.12g}" for a, b in zip(f, z, strict=True))
    return "frequency_hz,z_real_ohm,z_imag_ohm\n" + rows + "\n"


GREYBOX_NETLIST = """* tiny grey-box network (nodes U V W SN, frame 0)
R1 U 0 1k
R2 V 0 1k
R3 W 0 1k
C1 U SN 100p
C2 V SN 100p
C3 W SN 100p
C4 SN 0 1n
R4 SN 0 1meg
.end
"""

USER_MODEL = """* RC ladder
.param rs 50 5 500
R1 in n1 {rs}
C1 n1 0 10n [1n 100n]
R2 n1 n2 47
C2 n2 0 4.7n [0.5n 50n]
.port Zin in 0
.effect insulation_dielectric_loss C1 C2
.end
"""
