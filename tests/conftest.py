"""Shared fixtures: small datasets written to temporary directories."""

from __future__ import annotations

import os

# one BLAS thread per test process (set before numpy loads): batched solves on a shared
# 2-core machine are 10-100x slower with BLAS threads fighting the xdist workers
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import importlib.util  # noqa: E402
import shutil  # noqa: E402
from pathlib import Path  # noqa: E402
from types import ModuleType  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from benches.small_dataset import make_small_dataset  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
TOUCHSTONE_DIR = REPO / "data" / "touchstone"


def rlc_impedance(freq_hz: np.ndarray, r: float = 5.0, l_h: float = 2e-6,
                  c_f: float = 1e-9) -> np.ndarray:
    """Series R-L-C impedance, analytic."""
    s = 2j * np.pi * freq_hz
    return r + s * l_h + 1 / (s * c_f)


def load_script(name: str) -> ModuleType:
    """Import ``scripts/<name>.py`` as a module (scripts are not a package)."""
    spec = importlib.util.spec_from_file_location(name, REPO / "scripts" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def make_dataset(root: Path, n_samples: int = 4096) -> Path:
    """The small example dataset of :mod:`benches.small_dataset` (seeded)."""
    return make_small_dataset(root, seed=1, n_samples=n_samples)


@pytest.fixture
def tiny_dataset(tmp_path: Path) -> Path:
    return make_dataset(tmp_path / "tiny")


@pytest.fixture
def agilent(tmp_path: Path) -> Path:
    dst = tmp_path / "agilent.s4p"
    shutil.copy(TOUCHSTONE_DIR / "Agilent_E5071B.s4p", dst)
    return dst
