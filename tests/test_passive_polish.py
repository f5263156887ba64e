"""The polish (:mod:`vfmodel.fitting.passive_polish`) makes the enforcement's objective the
distance to the data: enforcing ``centred_on_data(m)`` for a passive model ``m`` gives the
passive model nearest the data among those with the poles of ``m``, whatever residues ``m``
has. Reference: the bounded-real lemma's optimum (tests/_bounded_real.py) for the same
poles, with the data's least-squares model as its origin (its change from that model is the
data distance up to a constant)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from tests._bounded_real import bounded_real_optimum
from vfmodel import RationalModel, read_spectrum, vector_fit
from vfmodel.fitting import check_passivity, enforce_passivity
from vfmodel.fitting._fit_report import fit_errors
from vfmodel.fitting.passive_polish import centred_on_data

ROOT = Path(__file__).resolve().parents[1]
MLIN = ROOT / "data" / "vfbench" / "mlin,djordjevicsvensson,kirschning.s2p"


def _scaled(model: RationalModel, k: float) -> RationalModel:
    return RationalModel(model.poles, k * model.residues, k * model.dd, model.ee, model.kind,
                         model.z0)


def test_polish_reaches_the_data_optimum_from_any_passive_start() -> None:
    # scikit-rf's microstrip line, 16 poles (the fit violates passivity above the band)
    data = read_spectrum(MLIN)
    fit, _ = vector_fit(data, order=16)
    margin = 1e-6
    enforced, rep = enforce_passivity(fit, data=data, margin=margin, keep_margin=False,
                                      weighting="uniform")
    assert rep.passive
    # a passive model with the same poles but residues 10 % off (0.9 S is passive when S
    # is), as a relocation round hands over: far from the data
    start = _scaled(enforced, 0.9)
    assert check_passivity(start).passive
    e_start = fit_errors(start, data)[1]
    polished, rep = enforce_passivity(centred_on_data(start, data, weighting="uniform"),
                                      data=data, margin=margin, keep_margin=False,
                                      weighting="uniform")
    assert rep.passive
    e_pol = fit_errors(polished, data)[1]
    # the bounded-real optimum with the data as objective: the fit's residues are the
    # data's least squares at its poles (ridge 1e-7), so the change from it is the distance
    optimum = bounded_real_optimum(fit, data.freq_hz, data.values, 1.0 - margin)
    e_opt = fit_errors(optimum, data)[1]
    # measured (SkylakeX, Haswell, Sandybridge kernels): start 0.1014, polished 0.015141,
    # the optimum 0.015141; the fit scaled by 0.9 and enforced directly 0.1011
    assert e_pol <= 0.2 * e_start, (e_pol, e_start)
    assert e_pol <= 1.01 * e_opt, (e_pol, e_opt)
    # the enforcement alone keeps a 10 %-off model near itself: the fit scaled by 0.9 (not
    # passive; the passive start above would be returned unchanged) enforced directly
    direct, _ = enforce_passivity(_scaled(fit, 0.9), data=data, margin=margin,
                                  keep_margin=False, weighting="uniform")
    assert fit_errors(direct, data)[1] >= 3 * e_pol


def test_polish_keeps_a_delay_and_is_no_farther_than_its_start() -> None:
    # the same line with a common delay of 40 ps put on the data and the model: the
    # polish works on the rational part against the data advanced by the delay
    data = read_spectrum(MLIN)
    tau = 40e-12
    delayed = replace(data, values=data.values
                      * np.exp(-2j * np.pi * data.freq_hz * tau)[:, None, None])
    fit, _ = vector_fit(data, order=16)
    enforced, _ = enforce_passivity(fit, data=data, margin=1e-6, keep_margin=False,
                                    weighting="uniform")
    start = RationalModel(enforced.poles, 0.9 * enforced.residues, 0.9 * enforced.dd,
                          enforced.ee, "S", enforced.z0, delay=tau)
    e_start = fit_errors(start, delayed)[1]
    polished = centred_on_data(start, delayed, weighting="uniform")
    assert polished.delay == tau
    passive, rep = enforce_passivity(polished, data=delayed, margin=1e-6, keep_margin=False,
                                     weighting="uniform")
    assert rep.passive
    # the undelayed case above gives the same error to 1e-3 (same poles, same data up to
    # the delay; measured: equal to 6 digits, 0.015141)
    undelayed, _ = enforce_passivity(centred_on_data(_scaled(enforced, 0.9), data,
                                                     weighting="uniform"),
                                     data=data, margin=1e-6, keep_margin=False,
                                     weighting="uniform")
    e_del, e_und = fit_errors(passive, delayed)[1], fit_errors(undelayed, data)[1]
    assert e_del <= 0.2 * e_start
    assert abs(e_del - e_und) <= 1e-3 * e_und, (e_del, e_und)


def test_fit_job_polish_step_and_its_share_of_the_time_limit() -> None:
    from functools import partial

    from vfmodel.fitting.vectfit import FitReport
    from vfmodel.pipeline.fit_job import _EnforceClock, _polish_retry

    data = read_spectrum(MLIN)
    fit, report = vector_fit(data, order=16)
    assert isinstance(report, FitReport)
    enforce = partial(enforce_passivity, data=data, margin=1e-6, keep_margin=False,
                      weighting="uniform")
    enforced = enforce(fit, max_iter=15)[0]
    start = _scaled(enforced, 0.9)
    first = (start, check_passivity(start), report)
    best = _polish_retry(data, first, enforce, 15, "uniform", bound=0.0)
    e = fit_errors(best[0], data)[1]
    assert best[1].passive
    # the step at the poles reaches the optimum there (0.015141 above; the step with real
    # poles added out of band gains nothing on this model: 0.015141 with the SkylakeX and
    # Haswell kernels); 1 % tolerance
    assert e <= 1.01 * fit_errors(enforced, data)[1], e
    assert best[2].order == best[0].n_poles
    assert "refitted to the data under the passivity constraint" in best[2].order_reason
    # the out-of-band poles are added once: the extended model's step finds them there
    from vfmodel.fitting.out_of_band_poles import with_out_of_band_poles
    once = with_out_of_band_poles(enforced, data.freq_hz)
    assert once.n_poles == enforced.n_poles + 5
    assert with_out_of_band_poles(once, data.freq_hz).n_poles == once.n_poles
    # a bound already met: nothing to do
    assert _polish_retry(data, first, enforce, 15, "uniform", bound=1.0) is first
    # the clock holds back its share from the retries until released
    clock = _EnforceClock(100.0, hold=0.15)
    left = clock.remaining()
    assert left is not None and 84.0 < left <= 85.0 and not clock.out()
    clock.release()
    left = clock.remaining()
    assert left is not None and 99.0 < left <= 100.0
    assert _EnforceClock(None, hold=0.15).remaining() is None
