"""Keep freed large arrays in the process's heap instead of returning them to the system.

glibc's ``malloc`` serves blocks above a threshold (128 kB, adapted up to 32 MB) with
``mmap`` and gives them back at ``free``; the next array of that size is mapped again and
every page of it is faulted in and zeroed by the kernel. The identification and the
detective allocate such arrays thousands of times per fit (transfers on ~10,000 record
bins, Jacobian blocks, LU values of ~350 frequencies): on independent bench 105
``vfmodel diagnose`` spent 21 s of system time in a 97-s run, 3 s with the thresholds
below (89 s; the same diagnosis). The CLI sets them at start (:func:`keep_large_blocks`);
a library user may call it too. At most :data:`TRIM_THRESHOLD` of free memory stays
mapped at the top of the heap.

Reference: ``mallopt(3)``, Linux man-pages (M_MMAP_THRESHOLD, M_TRIM_THRESHOLD,
M_TOP_PAD).
"""

from __future__ import annotations

import ctypes
import sys

__all__ = ["keep_large_blocks"]

_M_TRIM_THRESHOLD = -1
_M_TOP_PAD = -2
_M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD = 256 << 20      # blocks from here on are mapped (glibc's maximum is 32 MB)
TRIM_THRESHOLD = 512 << 20      # free memory at the top of the heap kept up to this
TOP_PAD = 64 << 20              # extra memory asked for when the heap grows


def keep_large_blocks() -> bool:
    """Set glibc's thresholds (module docstring); False where there is no glibc
    ``mallopt`` (other C libraries, other systems): nothing changes there."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    return all(mallopt(k, v) == 1 for k, v in ((_M_MMAP_THRESHOLD, MMAP_THRESHOLD),
                                                (_M_TRIM_THRESHOLD, TRIM_THRESHOLD),
                                                (_M_TOP_PAD, TOP_PAD)))
