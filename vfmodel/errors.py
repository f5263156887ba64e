"""Error and warning classes of vfmodel.

Every error subclasses a built-in class (ValueError for bad values, RuntimeError for
failures of an algorithm), so callers may catch either. Messages name the input (file or
argument), the place, what was found and what was expected.
"""

from __future__ import annotations


class VfmodelError(Exception):
    """Base class of every error raised on purpose by vfmodel."""


class InputError(VfmodelError, ValueError):
    """Bad user input: a file, an argument or data that does not meet the documented form.

    The CLI turns it into one line on stderr and exit status 2.
    """

    def __init__(
        self,
        message: str,
        *,
        source: str | None = None,
        place: str | None = None,
        found: str | None = None,
        expected: str | None = None,
    ) -> None:
        parts = [p for p in (source, place) if p]
        text = ": ".join([*parts, message])
        details = []
        if found is not None:
            details.append(f"found {found}")
        if expected is not None:
            details.append(f"expected {expected}")
        if details:
            text += " (" + "; ".join(details) + ")"
        super().__init__(text)
        self.source = source
        self.place = place
        self.found = found
        self.expected = expected


class FitError(VfmodelError, RuntimeError):
    """A fit could not produce a trustworthy model."""


class SolverError(VfmodelError, RuntimeError):
    """A numerical solver (cvxpy/Clarabel, least squares, eigen solver) did not succeed."""


class PassivityError(VfmodelError, RuntimeError):
    """Passivity could not be certified or enforced."""


class CircuitError(VfmodelError, ValueError):
    """A netlist is not well formed (floating node, bad value, short-circuited source...)."""


class SimulatorError(VfmodelError, RuntimeError):
    """An external simulator (ngspice) failed or is missing."""


class VfmodelWarning(UserWarning):
    """Base class of vfmodel warnings; each says how to fix the cause."""


class FitWarning(VfmodelWarning):
    """A fit converged poorly or hit a limit."""


class PassivityWarning(VfmodelWarning):
    """Passivity test fell back to sampling or enforcement changed the fit noticeably."""


class IllConditionedWarning(VfmodelWarning):
    """A matrix inversion is ill-conditioned (e.g. pure common-mode excitation in H1)."""


class SignalWarning(VfmodelWarning):
    """A recording looks suspicious (clipping, low SNR, short record)."""
