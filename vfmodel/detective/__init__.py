"""The discrepancy detective: locate where a network disagrees with the data beyond the
noise, name the missing physics, add it and show the fit improve (CONTRACT section 7).

Public names are imported lazily (PEP 562) so that importing one module of the package
does not load the others; ``__all__`` is the curated API. A function named like its module
(``identify``, ``simulate``, ``reproduce``, ...) is imported from that module.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vfmodel._lazy import lazy_exports

if TYPE_CHECKING:
    from vfmodel.detective.candidates import (
        TRANSFORMS,
        Transform,
        make_candidate,
    )
    from vfmodel.detective.diagnose import (
        Diagnosis,
        Finding,
        Trial,
        impedance_mape_pct,
    )
    from vfmodel.detective.fit import (
        FitResult,
        evaluate,
        refit,
    )
    from vfmodel.detective.locate import (
        Mismatch,
    )
    from vfmodel.detective.noise import (
        SpectrumNoise,
        spectrum_noise,
    )
    from vfmodel.detective.pmsm import (
        PmsmFamily,
        pmsm_family,
    )
    from vfmodel.detective.poles import (
        PoleComparison,
        compare_poles,
    )
    from vfmodel.detective.problem import (
        Candidate,
        Channel,
        Family,
        channel_slices,
        log_residual,
    )
    from vfmodel.detective.user_model import (
        UserFamily,
        UserModel,
        parse_user_model,
        read_user_model,
        user_family,
    )
    from vfmodel.detective.windows import (
        TimeWindow,
        noise_variance,
        time_windows,
    )

_EXPORTS: dict[str, str] = {
    "Diagnosis": "diagnose",
    "Finding": "diagnose",
    "Trial": "diagnose",
    "impedance_mape_pct": "diagnose",
    "Candidate": "problem",
    "Channel": "problem",
    "Family": "problem",
    "channel_slices": "problem",
    "log_residual": "problem",
    "TRANSFORMS": "candidates",
    "Transform": "candidates",
    "make_candidate": "candidates",
    "FitResult": "fit",
    "evaluate": "fit",
    "refit": "fit",
    "Mismatch": "locate",
    "SpectrumNoise": "noise",
    "spectrum_noise": "noise",
    "PoleComparison": "poles",
    "compare_poles": "poles",
    "TimeWindow": "windows",
    "noise_variance": "windows",
    "time_windows": "windows",
    "PmsmFamily": "pmsm",
    "pmsm_family": "pmsm",
    "UserFamily": "user_model",
    "UserModel": "user_model",
    "parse_user_model": "user_model",
    "read_user_model": "user_model",
    "user_family": "user_model",
}

__all__ = [
    "TRANSFORMS",
    "Candidate",
    "Channel",
    "Diagnosis",
    "Family",
    "Finding",
    "FitResult",
    "Mismatch",
    "PmsmFamily",
    "PoleComparison",
    "SpectrumNoise",
    "TimeWindow",
    "Transform",
    "Trial",
    "UserFamily",
    "UserModel",
    "channel_slices",
    "compare_poles",
    "evaluate",
    "impedance_mape_pct",
    "log_residual",
    "make_candidate",
    "noise_variance",
    "parse_user_model",
    "pmsm_family",
    "read_user_model",
    "refit",
    "spectrum_noise",
    "time_windows",
    "user_family",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)
