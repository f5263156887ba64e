"""A small ngspice runner (batch mode, subprocess) for tests, benchmarks and validation.

The netlist text is written to a temporary directory together with a ``.control`` block
that runs one analysis and writes the requested vectors with ``wrdata`` (ASCII, one
shared scale column); the output file is parsed and returned as an immutable result.

Public API
----------
``ngspice_available() -> bool``
    True when an ``ngspice`` executable is on ``PATH``.
``run_ac(netlist, probes, *, f_start_hz, f_stop_hz, points_per_decade=50, ...) -> AcResult``
    Small-signal ``.ac dec`` sweep. ``probes`` are ngspice vector expressions such as
    ``"v(out)"``, ``"v(a,b)"`` or ``"i(vsrc)"`` (the netlist must contain the ``AC``
    sources). ``AcResult.freq_hz (n_freq,)``, ``AcResult.values (n_freq, n_probes)``
    complex, columns in the order of ``probes``.
``run_tran(netlist, probes, *, t_step_s, t_stop_s, t_max_s=None, linearize=True, ...)``
    Transient analysis. With ``linearize=True`` the result is interpolated by ngspice onto
    the uniform grid ``0, t_step_s, 2 t_step_s, ...``. ``TranResult.time_s (n_t,)``,
    ``TranResult.values (n_probes, n_t)`` real (layout (channel, sample)).
``run_raw(netlist, control_lines, ...) -> str``
    Run arbitrary ``.control`` commands and return ngspice's log text (for anything else).

``netlist`` is the text of a circuit: a title line, elements, models, optional ``.options``
lines; a trailing ``.end`` is accepted and removed; it must not contain its own
``.control`` block. ``options`` (mapping) adds ``.options key=value`` lines, e.g.
``{"reltol": 1e-6}``. Every function raises :class:`vfmodel.errors.SimulatorError` when
ngspice is missing, times out, reports an error, or writes no output; the message quotes
the relevant lines of ngspice's log.

Precision: ``wrdata`` writes 16 significant digits; an AC analysis is one complex linear
solve per frequency, so results agree with an exact MNA solve to ~1e-12 relative on
well-conditioned networks.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from vfmodel.errors import SimulatorError

__all__ = [
    "AcResult",
    "TranResult",
    "ngspice_available",
    "run_ac",
    "run_raw",
    "run_tran",
]

_ERROR_PAT = re.compile(
    r"(error|singular matrix|timestep too small|could not find|unknown|no such vector"
    r"|not found|fatal|aborted)",
    re.IGNORECASE,
)


@dataclass(frozen=True)
class AcResult:
    """Result of :func:`run_ac`: ``values[k, j]`` is probe ``j`` at ``freq_hz[k]``."""

    freq_hz: NDArray[np.float64]
    probes: tuple[str, ...]
    values: NDArray[np.complex128]

    def __getitem__(self, probe: str) -> NDArray[np.complex128]:
        """Column of one probe, by the expression given to :func:`run_ac`."""
        return self.values[:, self.probes.index(probe)]


@dataclass(frozen=True)
class TranResult:
    """Result of :func:`run_tran`: ``values[j, k]`` is probe ``j`` at ``time_s[k]``."""

    time_s: NDArray[np.float64]
    probes: tuple[str, ...]
    values: NDArray[np.float64]

    def __getitem__(self, probe: str) -> NDArray[np.float64]:
        """Row of one probe, by the expression given to :func:`run_tran`."""
        return self.values[self.probes.index(probe)]


def ngspice_available() -> bool:
    """True when the ``ngspice`` executable is found on ``PATH``."""
    return shutil.which("ngspice") is not None


def _prepare(netlist: str, options: Mapping[str, float | str] | None) -> list[str]:
    lines = netlist.strip().splitlines()
    if not lines:
        raise SimulatorError("ngspice: empty netlist")
    if any(ln.strip().lower().startswith(".control") for ln in lines):
        raise SimulatorError(
            "ngspice: the netlist already has a .control block; pass netlist text without "
            "one (the runner adds its own)"
        )
    while lines and lines[-1].strip().lower() in (".end", ""):
        lines.pop()
    for key, value in (options or {}).items():
        lines.append(f".options {key}={value}")
    return lines


def _log_excerpt(log: str, limit: int = 12) -> str:
    hits = [ln.strip() for ln in log.splitlines() if _ERROR_PAT.search(ln)]
    if not hits:
        hits = [ln.strip() for ln in log.splitlines() if ln.strip()][-limit:]
    return "\n  ".join(hits[:limit])


def _run(
    lines: list[str], control: Sequence[str], workdir: Path, timeout_s: float
) -> str:
    exe = shutil.which("ngspice")
    if exe is None:
        raise SimulatorError(
            "ngspice is not installed (not on PATH); install it, e.g. 'apt-get install ngspice'"
        )
    text = "\n".join([*lines, ".control", *control, "quit 0", ".endc", ".end", ""])
    cir = workdir / "circuit.cir"
    cir.write_text(text)
    try:
        proc = subprocess.run(
            [exe, "-b", str(cir.name)],
            cwd=workdir,
            stdin=subprocess.DEVNULL,
            capture_output=True,
            text=True,
            timeout=timeout_s,
            check=False,
        )
    except subprocess.TimeoutExpired:
        raise SimulatorError(f"ngspice: no answer within {timeout_s:g} s") from None
    log = proc.stdout + "\n" + proc.stderr
    if proc.returncode != 0:
        raise SimulatorError(
            f"ngspice failed (exit status {proc.returncode}):\n  {_log_excerpt(log)}"
        )
    return log


def _read_wrdata(path: Path, log: str, n_cols: int) -> NDArray[np.float64]:
    if not path.exists():
        raise SimulatorError(f"ngspice wrote no output:\n  {_log_excerpt(log)}")
    try:
        data = np.loadtxt(path, skiprows=1, ndmin=2)
    except ValueError as err:
        raise SimulatorError(f"ngspice output could not be parsed: {err}") from None
    if data.shape[0] == 0 or data.shape[1] != n_cols:
        raise SimulatorError(
            f"ngspice output has shape {data.shape}, expected (n, {n_cols}):\n  "
            f"{_log_excerpt(log)}"
        )
    return data


def _check_probes(probes: Sequence[str]) -> tuple[str, ...]:
    out = tuple(str(p).strip() for p in probes)
    if not out:
        raise SimulatorError("ngspice: no probes requested")
    for p in out:
        if not re.fullmatch(r"[vViI]\([^()\s]+(,[^()\s]+)?\)", p):
            raise SimulatorError(
                f"ngspice: probe {p!r} not understood; expected 'v(node)', 'v(n1,n2)' or "
                "'i(vsource)'"
            )
    return out


def run_raw(
    netlist: str,
    control_lines: Sequence[str],
    *,
    options: Mapping[str, float | str] | None = None,
    timeout_s: float = 120.0,
) -> str:
    """Run ``control_lines`` inside a ``.control`` block; return ngspice's log text."""
    lines = _prepare(netlist, options)
    with tempfile.TemporaryDirectory(prefix="vfmodel-ngspice-") as tmp:
        return _run(lines, list(control_lines), Path(tmp), timeout_s)


def run_ac(
    netlist: str,
    probes: Sequence[str],
    *,
    f_start_hz: float,
    f_stop_hz: float,
    points_per_decade: int = 50,
    options: Mapping[str, float | str] | None = None,
    timeout_s: float = 120.0,
) -> AcResult:
    """Run ``ac dec points_per_decade f_start_hz f_stop_hz`` and return the probes.

    Parameters
    ----------
    netlist : str
        Circuit text (with at least one source having an ``AC`` value).
    probes : sequence of str
        ngspice vectors, e.g. ``["v(out)", "v(a,b)", "i(v1)"]``.
    f_start_hz, f_stop_hz : float
        Sweep limits (Hz), ``0 < f_start_hz <= f_stop_hz``.
    points_per_decade : int
        Logarithmic density of the sweep (ngspice's own frequency points are returned).

    Returns
    -------
    AcResult
        ``freq_hz (n_freq,)``, ``values (n_freq, n_probes)`` complex.
    """
    pr = _check_probes(probes)
    if not (0 < f_start_hz <= f_stop_hz) or points_per_decade < 1:
        raise SimulatorError(
            f"ngspice ac: bad sweep {f_start_hz!r}..{f_stop_hz!r} Hz, "
            f"{points_per_decade!r} points/decade"
        )
    lines = _prepare(netlist, options)
    control = [
        "set wr_singlescale",
        "set wr_vecnames",
        "option numdgt=15",
        f"ac dec {int(points_per_decade)} {f_start_hz:.15g} {f_stop_hz:.15g}",
        "wrdata out.txt " + " ".join(pr),
    ]
    with tempfile.TemporaryDirectory(prefix="vfmodel-ngspice-") as tmp:
        log = _run(lines, control, Path(tmp), timeout_s)
        data = _read_wrdata(Path(tmp) / "out.txt", log, 1 + 2 * len(pr))
    values = data[:, 1::2] + 1j * data[:, 2::2]
    return AcResult(freq_hz=data[:, 0].copy(), probes=pr, values=values)


def run_tran(
    netlist: str,
    probes: Sequence[str],
    *,
    t_step_s: float,
    t_stop_s: float,
    t_max_s: float | None = None,
    linearize: bool = True,
    uic: bool = False,
    options: Mapping[str, float | str] | None = None,
    timeout_s: float = 300.0,
) -> TranResult:
    """Run ``tran t_step_s t_stop_s 0 t_max_s`` and return the probes.

    Parameters
    ----------
    t_step_s, t_stop_s : float
        Print step and end time (s).
    t_max_s : float, optional
        Largest internal time step (default ``t_step_s``), bounds the integration error.
    linearize : bool
        Interpolate (ngspice ``linearize``) onto the uniform grid ``k * t_step_s``;
        otherwise the simulator's own time points are returned.
    uic : bool
        Skip the operating point (start from zero/initial conditions).

    Returns
    -------
    TranResult
        ``time_s (n_t,)``, ``values (n_probes, n_t)`` real.
    """
    pr = _check_probes(probes)
    if not (0 < t_step_s <= t_stop_s):
        raise SimulatorError(f"ngspice tran: bad times step {t_step_s!r}, stop {t_stop_s!r}")
    tmax = t_step_s if t_max_s is None else t_max_s
    lines = _prepare(netlist, options)
    control = [
        "set wr_singlescale",
        "set wr_vecnames",
        "option numdgt=15",
        f"tran {t_step_s:.15g} {t_stop_s:.15g} 0 {tmax:.15g}" + (" uic" if uic else ""),
    ]
    if linearize:
        control.append("linearize " + " ".join(pr))
    control.append("wrdata out.txt " + " ".join(pr))
    with tempfile.TemporaryDirectory(prefix="vfmodel-ngspice-") as tmp:
        log = _run(lines, control, Path(tmp), timeout_s)
        data = _read_wrdata(Path(tmp) / "out.txt", log, 1 + len(pr))
    return TranResult(time_s=data[:, 0].copy(), probes=pr, values=data[:, 1:].T.copy())
