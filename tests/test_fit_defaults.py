"""One default for the number of enforcement programs: library, fit job and CLI."""

from __future__ import annotations

import inspect

from vfmodel.cli.cmd_fit import fit
from vfmodel.fitting.defaults import ENFORCE_ITERATIONS
from vfmodel.fitting.passivity import enforce_passivity
from vfmodel.pipeline.fit_job import run_fit


def test_enforce_iterations_default_is_one_constant() -> None:
    lib = inspect.signature(enforce_passivity).parameters["max_iter"].default
    job = inspect.signature(run_fit).parameters["enforce_iterations"].default
    cli = next(p.default for p in fit.params if p.name == "enforce_iterations")
    assert lib == job == cli == ENFORCE_ITERATIONS
