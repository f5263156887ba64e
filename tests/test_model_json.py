"""model.json (CONTRACT section 4): contents, round trip, atomic write, bad files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tests._vf_models import known_model
from vfmodel import FrequencyData, vector_fit
from vfmodel.errors import InputError
from vfmodel.fitting.model_json import model_to_json, read_model_json, write_model_json

FREQ = np.geomspace(1e3, 1e7, 150)


def _fit() -> tuple[FrequencyData, object, object]:
    truth = known_model(2, 1, 2, seed=4)
    rng = np.random.default_rng(0)
    h = truth(FREQ) * (1 + 1e-3 * rng.normal(size=(FREQ.size, 2, 2)))
    data = FrequencyData(FREQ, h, kind="Z")
    model, report = vector_fit(data, 5, fit_e=True)
    return data, model, report


def test_contract_keys_and_errors(tmp_path: Path) -> None:
    data, model, report = _fit()
    path = write_model_json(tmp_path / "model.json", model, report, (1e3, 1e7), None)  # type: ignore[arg-type]
    obj = json.loads(path.read_text())
    for key in ("kind", "z0", "n_out", "n_in", "poles", "residues", "d", "e",
                "freq_range_hz", "rms_error", "rel_rms_error", "passive"):
        assert key in obj
    assert obj["passive"] is None and obj["kind"] == "Z" and obj["freq_range_hz"] == [1e3, 1e7]
    assert np.array(obj["residues"]).shape == (5, 2, 2, 2)
    # reference: CONTRACT definition recomputed from the written model and the data
    back = read_model_json(path)
    diff = back(FREQ) - data.values
    rel = np.linalg.norm(diff) / np.linalg.norm(data.values)
    rms = np.sqrt(np.mean(np.abs(diff) ** 2))
    assert obj["rel_rms_error"] == pytest.approx(rel, rel=1e-9)
    assert obj["rms_error"] == pytest.approx(rms, rel=1e-9)


def test_round_trip_exact(tmp_path: Path) -> None:
    _, model, report = _fit()
    path = write_model_json(tmp_path / "m.json", model, report, (1e3, 1e7), True)  # type: ignore[arg-type]
    back = read_model_json(path)
    # reference: the in-memory model, bit-exact through JSON floats
    assert np.array_equal(back.poles, model.poles)  # type: ignore[attr-defined]
    assert np.array_equal(back.residues, model.residues)  # type: ignore[attr-defined]
    assert np.array_equal(back.dd, model.dd)  # type: ignore[attr-defined]
    assert np.array_equal(back.ee, model.ee)  # type: ignore[attr-defined]
    assert json.loads(path.read_text())["passive"] is True
    # atomic write: no temporary file left beside the result
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.json"]


def test_without_report() -> None:
    _, model, _ = _fit()
    obj = model_to_json(model, None, (0.0, 1e7), False)  # type: ignore[arg-type]
    assert obj["rms_error"] is None and obj["rel_rms_error"] is None and obj["passive"] is False


def test_bad_files(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(InputError, match="not valid JSON"):
        read_model_json(bad)
    bad.write_text(json.dumps({"kind": "Z"}))
    with pytest.raises(InputError, match="not a vfmodel model"):
        read_model_json(bad)
    with pytest.raises(InputError, match="cannot read model file"):
        read_model_json(tmp_path / "missing.json")
    _, model, report = _fit()
    with pytest.raises(InputError, match="freq_range_hz"):
        model_to_json(model, report, (1e7, 1e3), None)  # type: ignore[arg-type]
