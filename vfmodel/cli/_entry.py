"""The installed ``vfmodel`` console script: Ctrl-C exits 130 without a traceback, also
while Python is still importing the command (start-up)."""

from __future__ import annotations

import os
import signal
import sys
from types import FrameType


def _interrupted_at_startup(signum: int, frame: FrameType | None) -> None:
    os.write(2, b"vfmodel: interrupted\n")
    os._exit(130)


def entry() -> None:
    """Run ``vfmodel``; exit status as :func:`vfmodel.cli.main.main` returns it."""
    signal.signal(signal.SIGINT, _interrupted_at_startup)
    from vfmodel.cli.main import main

    # from here KeyboardInterrupt unwinds normally: staged outputs are removed, exit 130
    signal.signal(signal.SIGINT, signal.default_int_handler)
    code = main()
    sys.stdout.flush()
    sys.exit(code)
