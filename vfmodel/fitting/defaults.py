"""Defaults shared by the library, the ``fit`` job and the CLI (no imports: the CLI reads
them without loading numpy)."""

ENFORCE_ITERATIONS = 30
"""Convex programs of a passivity enforcement at most (``enforce_passivity(max_iter=)``,
``run_fit(enforce_iterations=)``, ``vfmodel fit --enforce-iterations``)."""

ENFORCE_TIME_LIMIT = 300.0
"""Seconds from the start of passivity enforcement in ``fit --passive`` after which the
running convex program stops and no further one starts, in the first enforcement (after
its first program) or its retries (out-of-band poles, anchored refits, pole relocation
against the passive model), for the S models of at most 4 ports that get retries
(``run_fit(enforce_time_limit=)``, ``vfmodel fit --enforce-time-limit``, 0 for none). A
calculated 2-port line match (191 points) ran its retries for more than 35 minutes, 2-12 s
per convex program; a 4-port coupler's first enforcement more than 14 minutes."""
