"""What the automatic order says about itself: data sampled too coarsely for a noise
estimate, and a reason text that agrees with the order it reports."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from vfmodel import FrequencyData, read_spectrum, vector_fit
from vfmodel.errors import FitWarning
from vfmodel.fitting._order import NOISE_UNRESOLVED, estimate_noise
from vfmodel.fitting._vf_core import Problem

DATA = Path(__file__).resolve().parents[1] / "data" / "vfbench"


def _line(f: np.ndarray, tau: float = 0.95e-9) -> np.ndarray:
    """A matched 2-port line of delay tau with a far-end reflection (analytic)."""
    w = 2 * np.pi * f
    s = np.empty((f.size, 2, 2), complex)
    s[:, 0, 1] = s[:, 1, 0] = 0.9 * np.exp(-1j * w * tau)
    s[:, 0, 0] = s[:, 1, 1] = 0.2 * np.exp(-2j * w * tau)
    return s


def test_coarsely_sampled_delay_is_not_called_noise() -> None:
    # 0.483 GHz steps of a 0.95 ns line: S21 turns 2.9 rad per sample (analytic
    # 2 pi 0.483e9 0.95e-9), about 2 samples per turn
    f = np.linspace(1e9, 30e9, 61)
    data = FrequencyData(f, _line(f), kind="S")
    h = data.values.reshape(f.size, -1)
    prob = Problem(1j * f / f[-1] + 0j, h, np.ones((f.size, 1)), True, False, None)
    # the difference-based estimator measures the data itself (noise-free samples)
    assert estimate_noise(prob) > NOISE_UNRESOLVED
    with pytest.warns(FitWarning, match="sampled too coarsely"):
        _, report = vector_fit(data, max_order=20)
    assert report.noise_floor is None
    assert "could not be estimated" in report.order_reason
    assert "noise floor estimate" not in report.order_reason
    # the fit is poor (no rational model resolves 2 samples per turn) and says why
    assert report.rel_rms_error > 0.5
    (note,) = report.notes
    assert "sampled too coarsely" in note
    step = float(re.search(r"advances by ([0-9.]+) rad", note).group(1))  # type: ignore[union-attr]
    assert abs(step - 2 * np.pi * (29e9 / 60) * 0.95e-9) < 0.05


def test_finely_sampled_delay_keeps_its_noise_floor() -> None:
    # the same line with 5 MHz steps (0.03 rad per sample): a noise floor is estimated
    # and the fit is accurate (reference: the analytic samples, error < 1e-5)
    f = np.linspace(1e9, 2e9, 201)
    _, report = vector_fit(FrequencyData(f, _line(f), kind="S"))
    assert report.noise_floor is not None
    assert report.rel_rms_error < 1e-5
    assert report.notes == ()


def test_order_reason_agrees_with_the_order() -> None:
    # cpw.s2p: 21 samples, order limit 2*21-3 = 39; the text used to read "order 17:
    # maximum order 39 reached". Which rule stops the growth (the limit, or the plateau)
    # depends on the rounding of the BLAS kernel (Haswell: the limit, 17 poles kept;
    # Sandybridge: the plateau at 17): the text must agree with the order either way.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        _, report = vector_fit(read_spectrum(DATA / "cpw.s2p").to_kind("S"), delay="auto")
    head = re.match(r"order (\d+):", report.order_reason)
    assert head is not None and int(head.group(1)) == report.order
    if report.order < 39:
        assert "maximum order 39 reached" not in report.order_reason
        assert "maximum order 39 was reached" not in report.order_reason
    if "maximum order 39" in report.order_reason and report.order < 39:
        assert "growth stopped at the maximum order 39" in report.order_reason
