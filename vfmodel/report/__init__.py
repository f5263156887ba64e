"""Figures (matplotlib, imported lazily) and HTML reports; the only package that plots.

Public names are imported lazily (PEP 562) so that importing one module of the package
does not load the others; ``__all__`` is the curated API. A function named like its module
(``identify``, ``simulate``, ``reproduce``, ...) is imported from that module.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vfmodel._lazy import lazy_exports

if TYPE_CHECKING:
    from vfmodel.report.batch_html import (
        write_batch_summary,
    )
    from vfmodel.report.diagnose_figures import (
        write_diagnose_figures,
    )
    from vfmodel.report.diagnose_html import (
        write_diagnose_html,
    )
    from vfmodel.report.fit_figures import (
        plot_fit,
    )
    from vfmodel.report.fit_html import (
        write_fit_html,
    )
    from vfmodel.report.html import (
        reproduce_html,
        write_reproduce_html,
    )
    from vfmodel.report.predict_figures import (
        plot_prediction,
    )
    from vfmodel.report.reproduce_figures import (
        write_figures,
    )
    from vfmodel.report.units import (
        parse_si,
        si,
    )

_EXPORTS: dict[str, str] = {
    "plot_fit": "fit_figures",
    "write_fit_html": "fit_html",
    "write_figures": "reproduce_figures",
    "reproduce_html": "html",
    "write_reproduce_html": "html",
    "write_diagnose_figures": "diagnose_figures",
    "write_diagnose_html": "diagnose_html",
    "plot_prediction": "predict_figures",
    "write_batch_summary": "batch_html",
    "parse_si": "units",
    "si": "units",
}

__all__ = [
    "parse_si",
    "plot_fit",
    "plot_prediction",
    "reproduce_html",
    "si",
    "write_batch_summary",
    "write_diagnose_figures",
    "write_diagnose_html",
    "write_figures",
    "write_fit_html",
    "write_reproduce_html",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)
