"""Defaults shared by the library, the ``fit`` job and the CLI (no imports: the CLI reads
them without loading numpy)."""

ENFORCE_ITERATIONS = 30
"""Convex programs of a passivity enforcement at most (``enforce_passivity(max_iter=)``,
``run_fit(enforce_iterations=)``, ``vfmodel fit --enforce-iterations``)."""
