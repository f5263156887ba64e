"""Immutable data types, file formats and atomic output: the bottom layer.

Owns: :class:`FrequencyData`, :class:`RationalModel`, :class:`Recording`, :class:`Dataset`
(validated once, frozen); readers and writers of spectra (Touchstone, CSV), recordings (NPZ,
CSV) and datasets (``dataset.toml``); atomic and staged file output, strict JSON; text
files read with clear errors. Imports nothing else from vfmodel except ``errors``.

Public names are imported lazily (PEP 562) so that importing one module of the package
does not load the others; ``__all__`` is the curated API. A function named like its module
(``identify``, ``simulate``, ``reproduce``, ...) is imported from that module.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vfmodel._lazy import lazy_exports

if TYPE_CHECKING:
    from vfmodel.core.atomic import (
        atomic_directory,
        atomic_path,
        atomic_write_text,
        check_output_place,
        finite_json,
        staged_output,
        write_json,
    )
    from vfmodel.core.dataset import (
        Dataset,
        SpeedImpedance,
    )
    from vfmodel.core.frequency_data import (
        FrequencyData,
        as_frequency_data,
    )
    from vfmodel.core.io_dataset import (
        dataset_file,
        read_dataset,
    )
    from vfmodel.core.io_recording import (
        read_recording,
        write_recording,
    )
    from vfmodel.core.io_spectrum import (
        csv_text,
        read_spectrum,
        spectrum_format,
        write_spectrum,
    )
    from vfmodel.core.machine_info import (
        BearingInfo,
        MachineInfo,
        PriorOverride,
    )
    from vfmodel.core.progress import (
        Progress,
        no_progress,
    )
    from vfmodel.core.rational_model import (
        RationalModel,
        StateSpace,
    )
    from vfmodel.core.recording import (
        Recording,
    )
    from vfmodel.core.text import (
        read_text_file,
    )

_EXPORTS: dict[str, str] = {
    "FrequencyData": "frequency_data",
    "as_frequency_data": "frequency_data",
    "RationalModel": "rational_model",
    "StateSpace": "rational_model",
    "Recording": "recording",
    "Dataset": "dataset",
    "SpeedImpedance": "dataset",
    "MachineInfo": "machine_info",
    "BearingInfo": "machine_info",
    "PriorOverride": "machine_info",
    "read_spectrum": "io_spectrum",
    "write_spectrum": "io_spectrum",
    "spectrum_format": "io_spectrum",
    "csv_text": "io_spectrum",
    "read_recording": "io_recording",
    "write_recording": "io_recording",
    "read_dataset": "io_dataset",
    "dataset_file": "io_dataset",
    "atomic_path": "atomic",
    "atomic_write_text": "atomic",
    "atomic_directory": "atomic",
    "staged_output": "atomic",
    "check_output_place": "atomic",
    "write_json": "atomic",
    "finite_json": "atomic",
    "read_text_file": "text",
    "Progress": "progress",
    "no_progress": "progress",
}

__all__ = [
    "BearingInfo",
    "Dataset",
    "FrequencyData",
    "MachineInfo",
    "PriorOverride",
    "Progress",
    "RationalModel",
    "Recording",
    "SpeedImpedance",
    "StateSpace",
    "as_frequency_data",
    "atomic_directory",
    "atomic_path",
    "atomic_write_text",
    "check_output_place",
    "csv_text",
    "dataset_file",
    "finite_json",
    "no_progress",
    "read_dataset",
    "read_recording",
    "read_spectrum",
    "read_text_file",
    "spectrum_format",
    "staged_output",
    "write_json",
    "write_recording",
    "write_spectrum",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)
