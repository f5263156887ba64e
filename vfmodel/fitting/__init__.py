"""Vector fitting, order selection, passivity check and enforcement, model.json.

The underscore modules are private implementation; use the names below.

Public names are imported lazily (PEP 562) so that importing one module of the package
does not load the others; ``__all__`` is the curated API. A function named like its module
(``identify``, ``simulate``, ``reproduce``, ...) is imported from that module.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vfmodel._lazy import lazy_exports

if TYPE_CHECKING:
    from vfmodel.fitting.artifacts import (
        DataArtifacts,
        find_artifacts,
    )
    from vfmodel.fitting.data_passivity import (
        DataPassivity,
    )
    from vfmodel.fitting.model_json import (
        model_to_json,
        passivity_to_json,
        read_model_json,
        write_model_json,
    )
    from vfmodel.fitting.passivity import (
        PassivityReport,
        check_passivity,
        enforce_passivity,
        passivity_margin,
    )
    from vfmodel.fitting.vectfit import (
        FitReport,
        FitStep,
        data_noise,
        fit_errors,
        point_errors,
        vector_fit,
    )

_EXPORTS: dict[str, str] = {
    "FitReport": "vectfit",
    "FitStep": "vectfit",
    "fit_errors": "vectfit",
    "point_errors": "vectfit",
    "vector_fit": "vectfit",
    "data_noise": "vectfit",
    "PassivityReport": "passivity",
    "check_passivity": "passivity",
    "enforce_passivity": "passivity",
    "passivity_margin": "passivity",
    "DataArtifacts": "artifacts",
    "find_artifacts": "artifacts",
    "DataPassivity": "data_passivity",
    "model_to_json": "model_json",
    "passivity_to_json": "model_json",
    "read_model_json": "model_json",
    "write_model_json": "model_json",
}

__all__ = [
    "DataArtifacts",
    "DataPassivity",
    "FitReport",
    "FitStep",
    "PassivityReport",
    "check_passivity",
    "data_noise",
    "enforce_passivity",
    "find_artifacts",
    "fit_errors",
    "model_to_json",
    "passivity_margin",
    "passivity_to_json",
    "point_errors",
    "read_model_json",
    "vector_fit",
    "write_model_json",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)
