"""The lubricant stages' low-rank transfer (vfmodel.greybox.identify.low_rank_stage and
RecordTransfer.low_rank_error), against sparse solves of the whole network.

Reference: ``MnaSystem.solve(method="sparse")`` (one LU factorisation per frequency)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from tests.conftest import REPO
from vfmodel.core.io_dataset import read_dataset
from vfmodel.greybox.assembly import default_params, lubricant_names
from vfmodel.greybox.identify import LOW_RANK_TOL, StageReport, low_rank_stage
from vfmodel.greybox.network import NetSpec
from vfmodel.greybox.objective import RecordTransfer, prepare_recording, values_of
from vfmodel.greybox.params import ParamSet
from vfmodel.greybox.record_fit import RecordTerm, record_term

P0 = default_params()
# the film and contact far from where the form was made: the contact resistance x 1e3,
# the thickener layer x 30, the edge capacitance / 5
MOVED = P0.with_values({"bearing.R_h": P0["bearing.R_h"] * 1e3,
                        "lubricant.R_2": P0["lubricant.R_2"] * 30,
                        "bearing.C_edge": P0["bearing.C_edge"] / 5}, clip=True)


@pytest.fixture(scope="module")
def term() -> RecordTerm:
    ds = read_dataset(REPO / "data" / "concealed" / "pmsm_null")
    rec = next(r for r in ds.recordings if r.speed_rpm == 100.0)
    return record_term(prepare_recording(rec), NetSpec(), P0, "rotating")


def _sparse(term: RecordTerm, p: ParamSet) -> np.ndarray:
    v = values_of(p, term.spec, term.state, sources=True)
    return term.mna.solve(term.prep.bins_hz, term.b, term.cout, v, method="sparse").h


def test_low_rank_error_against_sparse_solves(term: RecordTerm) -> None:
    """The form from exact references meets the network far from its reference (measured
    1e-11 to 2e-6 of the largest transfer on such moves), and ``low_rank_error`` says so;
    a form whose node impedances are off by 1e-3 is caught (its error is that of the
    form, computed independently here)."""
    lub = lubricant_names(P0, term.spec.effects)
    assert term.use_low_rank(P0, lub)
    exact = _sparse(term, MOVED)
    scale = np.abs(exact).max()
    lr = term._memo.lowrank
    assert lr is not None
    v = values_of(MOVED, term.spec, term.state, sources=True)
    own = np.abs(lr(v) - exact).max() / scale
    assert own <= 1e-8          # exact references: rounding (measured 6e-12)
    # the check compares with transfer_on, accurate here to ~4e-9 of the largest transfer
    assert term.low_rank_error(MOVED) == pytest.approx(own, abs=1e-7)
    bad = replace(lr, m=lr.m * (1 + 1e-3))
    term._memo.lowrank = bad
    miss = np.abs(bad(v) - exact).max() / scale
    assert miss > LOW_RANK_TOL
    assert term.low_rank_error(MOVED) == pytest.approx(miss, rel=1e-3)
    # where the form does not apply (a machine value moved), nothing to check
    other = MOVED.with_values({"airgap.C_rf": 2 * MOVED["airgap.C_rf"]})
    assert term.low_rank_error(other) == 0.0
    term.drop_low_rank()
    assert term._memo.lowrank is None
    np.testing.assert_allclose(term.transfer_bins(MOVED), exact, rtol=0, atol=1e-6 * scale)


def test_a_form_is_reused_only_where_it_applies(term: RecordTerm) -> None:
    """Reused when the fixed elements and bins are the same (exact there: the references
    hold for any film values); a form made where a machine value differs is not taken."""
    lub = lubricant_names(P0, term.spec.effects)
    assert term.use_low_rank(P0, lub)
    form = term.low_rank
    assert term.use_low_rank(MOVED, lub, reuse=form) and term.low_rank is form
    exact = _sparse(term, MOVED)
    np.testing.assert_allclose(term.transfer_bins(MOVED), exact, rtol=0,
                               atol=1e-9 * np.abs(exact).max())
    other = P0.with_values({"airgap.C_rf": 2 * P0["airgap.C_rf"]})
    assert term.use_low_rank(other, lub, reuse=form) and term.low_rank is not form
    term.drop_low_rank()


def test_a_stage_whose_form_misses_is_fitted_again_without_it(
        term: RecordTerm, monkeypatch: pytest.MonkeyPatch) -> None:
    """One fit when the form holds at the fitted values; a second fit with the network
    solved at every evaluation when it misses; afterwards the term solves the network
    (its transfer is the sparse solve's)."""
    lub = lubricant_names(P0, term.spec.effects)
    seen: list[bool] = []
    rep = StageReport("lubricant 100 rpm", tuple(lub), 10, 1.0, 1, 1)

    def fit() -> tuple[ParamSet, StageReport]:
        seen.append(term._memo.lowrank is not None)
        term.transfer_bins(MOVED)
        return MOVED, rep

    p, r, form = low_rank_stage(term, P0, lub, fit)
    assert (p, r) == (MOVED, rep) and form is not None
    assert seen == [True] and term._memo.lowrank is None
    # the next speed's stage takes the same form (same network and bins), not a new one
    seen.clear()
    p, r, again = low_rank_stage(term, MOVED, lub, fit, reuse=form)
    assert again is form and seen == [True]
    seen.clear()
    monkeypatch.setattr(RecordTransfer, "low_rank_error", lambda self, p: 2 * LOW_RANK_TOL)
    p, r, _ = low_rank_stage(term, P0, lub, fit)
    assert (p, r) == (MOVED, rep)
    assert seen == [True, False] and term._memo.lowrank is None
    exact = _sparse(term, MOVED)
    np.testing.assert_allclose(term.transfer_bins(MOVED), exact, rtol=0,
                               atol=1e-6 * np.abs(exact).max())
