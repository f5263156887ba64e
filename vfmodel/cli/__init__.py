"""The ``vfmodel`` command: parse, call a pipeline job, print, exit codes (CONTRACT section 3).

Public names are imported lazily (PEP 562) so that importing one module of the package
does not load the others; ``__all__`` is the curated API. A function named like its module
(``identify``, ``simulate``, ``reproduce``, ...) is imported from that module.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vfmodel._lazy import lazy_exports

if TYPE_CHECKING:
    from vfmodel.cli.main import (
        cli,
    )

_EXPORTS: dict[str, str] = {
    "cli": "main",
}

__all__ = [
    "cli",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)
