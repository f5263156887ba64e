"""The jobs behind the commands: fit, reproduce, diagnose, predict, batch, info. They
compose the layers below and return results; files are written by the CLI and ``report``.

Public names are imported lazily (PEP 562) so that importing one module of the package
does not load the others; ``__all__`` is the curated API. A function named like its module
(``identify``, ``simulate``, ``reproduce``, ...) is imported from that module.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vfmodel._lazy import lazy_exports

if TYPE_CHECKING:
    from vfmodel.pipeline.batch import (
        Job,
        JobResult,
        run_batch,
    )
    from vfmodel.pipeline.diagnose import (
        DiagnoseResult,
        diagnosis_json,
        run_diagnose,
    )
    from vfmodel.pipeline.fit_job import (
        FitJobResult,
        fit_model_json,
        fit_spice_text,
        run_fit,
        spectrum_summary,
    )
    from vfmodel.pipeline.predict import (
        Prediction,
        check_inverter_options,
        check_model_nodes,
        inverter_options,
        predict_inverter,
        predict_recording,
    )
    from vfmodel.pipeline.reproduce import (
        ReproduceResult,
        SpeedResult,
        netlist_text,
        rpm_key,
    )
    from vfmodel.pipeline.summary import (
        dataset_summary,
        spectrum_noise_pct,
    )

_EXPORTS: dict[str, str] = {
    "FitJobResult": "fit_job",
    "fit_model_json": "fit_job",
    "fit_spice_text": "fit_job",
    "run_fit": "fit_job",
    "spectrum_summary": "fit_job",
    "ReproduceResult": "reproduce",
    "SpeedResult": "reproduce",
    "netlist_text": "reproduce",
    "rpm_key": "reproduce",
    "DiagnoseResult": "diagnose",
    "diagnosis_json": "diagnose",
    "run_diagnose": "diagnose",
    "Prediction": "predict",
    "check_inverter_options": "predict",
    "check_model_nodes": "predict",
    "inverter_options": "predict",
    "predict_inverter": "predict",
    "predict_recording": "predict",
    "Job": "batch",
    "JobResult": "batch",
    "run_batch": "batch",
    "dataset_summary": "summary",
    "spectrum_noise_pct": "summary",
}

__all__ = [
    "DiagnoseResult",
    "FitJobResult",
    "Job",
    "JobResult",
    "Prediction",
    "ReproduceResult",
    "SpeedResult",
    "check_inverter_options",
    "check_model_nodes",
    "dataset_summary",
    "diagnosis_json",
    "fit_model_json",
    "fit_spice_text",
    "inverter_options",
    "netlist_text",
    "predict_inverter",
    "predict_recording",
    "rpm_key",
    "run_batch",
    "run_diagnose",
    "run_fit",
    "spectrum_noise_pct",
    "spectrum_summary",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)
