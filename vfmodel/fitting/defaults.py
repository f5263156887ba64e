"""Defaults shared by the library, the ``fit`` job and the CLI (no imports: the CLI reads
them without loading numpy)."""

ENFORCE_ITERATIONS = 30
"""Convex programs of a passivity enforcement at most (``enforce_passivity(max_iter=)``,
``run_fit(enforce_iterations=)``, ``vfmodel fit --enforce-iterations``)."""

ENFORCE_TIME_LIMIT = 300.0
"""Seconds after the first passivity enforcement of ``fit --passive`` from which its
retries (out-of-band poles, anchored refits, pole relocation against the passive model)
start no further enforcement (``run_fit(enforce_time_limit=)``, ``vfmodel fit
--enforce-time-limit``, 0 for none). A calculated 2-port line match (191 points) ran its
retries for more than 35 minutes, 2-12 s per convex program."""
