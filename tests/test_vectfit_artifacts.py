"""Samples that are not data: export padding and isolated spikes (find_artifacts), and
fitting without them (vector_fit(exclude=...), the fit job's default)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from tests._vf_models import known_model, relative_pole_error
from vfmodel import FrequencyData, vector_fit
from vfmodel.errors import FitWarning, InputError
from vfmodel.fitting.artifacts import find_artifacts
from vfmodel.pipeline.fit_job import run_fit

REPO = Path(__file__).resolve().parents[1]
_DIRS = [REPO.parent / "shared" / "data" / "touchstone", REPO / "data" / "touchstone"]
TOUCHSTONE = next((d for d in _DIRS if d.is_dir()), _DIRS[0])
FREQ = np.geomspace(1e3, 1e7, 240)


def _spiked(k_spike: int, n_pad: int) -> tuple[FrequencyData, FrequencyData]:
    """Known 2-port Z (analytic truth) with one spike in Z12 and ``n_pad`` padded samples."""
    truth = known_model(2, 1, 3, seed=3, with_e=False)
    h = truth(FREQ)
    rms = float(np.sqrt(np.mean(np.abs(h) ** 2)))
    bad = h.copy()
    bad[k_spike, 0, 1] += 0.02 * rms * (1 + 1j)
    f_pad = np.concatenate([FREQ, FREQ[-1] * (1 + 0.01 * np.arange(1, n_pad + 1))])
    bad = np.concatenate([bad, np.repeat(bad[-1:], n_pad, axis=0)])
    return FrequencyData(FREQ, h, kind="Z"), FrequencyData(f_pad, bad, kind="Z")


def test_padding_and_spike_found_exactly() -> None:
    _, data = _spiked(117, 20)
    art = find_artifacts(data)
    # reference: what was injected (20 repeats of sample 239, one spike at 117)
    assert art.n_genuine == FREQ.size
    assert art.padded_from_hz == pytest.approx(FREQ[-1] * 1.01, rel=1e-12)
    assert art.spikes == (117,)
    assert art.spike_freq_hz == (pytest.approx(FREQ[117], rel=1e-12),)


@pytest.mark.parametrize("q", [30.0, 300.0, 1e4])
def test_sharp_resonance_is_not_a_spike(q: float) -> None:
    # analytic R + sL + parallel RLC with its peak exactly on a sample (log grid, 2.3 %
    # spacing, bandwidth down to 1e-4 of the frequency): smooth data, nothing to flag
    f = np.logspace(3, 7, 400)
    s, w0 = 2j * np.pi * f, 2 * np.pi * f[200]
    z = 1 + s * 1e-6 + 1e3 * (w0 / q) * s / (s**2 + (w0 / q) * s + w0**2)
    art = find_artifacts(FrequencyData(f, z, kind="Z"))
    assert not art.found and art.n_genuine == f.size


def test_exclude_recovers_the_model_under_a_spike() -> None:
    truth_data, data = _spiked(117, 0)
    truth = known_model(2, 1, 3, seed=3, with_e=False)
    art = find_artifacts(data)
    model, report = vector_fit(data, truth.n_poles, exclude=art.spikes)
    # reference: the analytic poles (1e-8) and the clean response (1e-9 relative)
    assert relative_pole_error(model.poles, truth.poles) < 1e-8
    clean = np.linalg.norm(model(FREQ) - truth_data.values) / np.linalg.norm(truth_data.values)
    assert clean < 1e-9
    # the report still counts the spike: its error is the injected one
    assert report.max_abs_error == pytest.approx(
        0.02 * np.sqrt(2) * np.sqrt(np.mean(np.abs(truth_data.values) ** 2)), rel=1e-6
    )
    # without exclude the spike pulls the poles away (the test can fail)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        spoiled, _ = vector_fit(data, truth.n_poles)
    assert relative_pole_error(spoiled.poles, truth.poles) > 1e-6


def test_exclude_bad_input() -> None:
    truth_data, _ = _spiked(117, 0)
    with pytest.raises(InputError, match="exclude"):
        vector_fit(truth_data, 4, exclude=(FREQ.size,))
    with pytest.raises(InputError, match="exclude"):
        vector_fit(truth_data, 4, exclude=tuple(range(FREQ.size - 2)))


def test_cst_file_artifacts_and_fit_job() -> None:
    skrf = pytest.importorskip("skrf")
    path = TOUCHSTONE / "cst_example_4ports.s4p"
    if not path.exists():
        pytest.skip(f"{path} missing")
    data = FrequencyData.from_network(skrf.Network(str(path)), kind="S", source=path.name)
    art = find_artifacts(data)
    # reference: the file itself -- 40.1-60 MHz repeat the 40 MHz sample bit for bit, and
    # S14/S23 jump by 0.0956 at 19.9 MHz (sigma_max 1.085), S11 by 3.3e-4 at 30 MHz
    assert art.n_genuine == 401 and art.padded_from_hz == 40.1e6
    assert art.spikes == (199, 300)
    with pytest.warns(FitWarning, match="export padding"):
        res = run_fit([data], passive=False)
    assert res.data.n_freq == 401 and res.artifacts == art
    # no pole narrower than the 100 kHz sample spacing (the spike is not chased)
    assert np.min(-res.model.poles.real) > 2 * np.pi * 100e3
    # the fit of the clean samples is at the data's 6-digit level (< 2e-5 RMS)
    ok = np.setdiff1d(np.arange(401), art.spikes)
    err = res.model(res.data.freq_hz[ok]) - res.data.values[ok]
    assert float(np.sqrt(np.mean(np.abs(err) ** 2))) < 2e-5
