"""The winding-section count chosen by the rotating records
(:mod:`vfmodel.greybox.section_choice`, ``reproduce --sections-by records``)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from tests.conftest import load_script
from vfmodel.cli.main import main
from vfmodel.core.dataset import Dataset
from vfmodel.core.io_dataset import read_dataset
from vfmodel.errors import InputError
from vfmodel.greybox.identify import identify
from vfmodel.greybox.section_choice import (
    identify_by_records,
    neighbour_sections,
    record_score,
)
from vfmodel.pipeline.reproduce import reproduce


@pytest.fixture(scope="module")
def bench(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The small test bench the real identifications below share (read only)."""
    ds = tmp_path_factory.mktemp("sections") / "bench"
    load_script("make_testbench").make_bench(ds, seed=2, speeds=(0.0, 200.0), periods=1,
                                             n_freq=81, n_coils=2, n_rungs=4)
    return ds


def _fake(n: int, chi2: list[float], standstill: bool = True) -> Any:
    """An Identification-like object: ``n`` sections, rotating speeds whose record terms
    give whitened residuals of mean square ``chi2`` (four equal entries each). Their stage
    reports say 0.5, as a kept joint stage's report would: the score must not read them."""
    def record(c: float) -> Any:
        return SimpleNamespace(residual=lambda p: (np.full(4, math.sqrt(c)), None))

    speeds = [SimpleNamespace(speed_rpm=100.0 * (k + 1), state="rotating", params=None,
                              report=SimpleNamespace(chi2_red=0.5), record=record(c),
                              term=SimpleNamespace(prep=k))
              for k, c in enumerate(chi2)]
    if standstill:
        speeds.insert(0, SimpleNamespace(speed_rpm=0.0, state="standstill", report=None,
                                         record=None, term=SimpleNamespace(prep="p0")))
    return SimpleNamespace(spec=SimpleNamespace(n_sections=n), speeds=tuple(speeds),
                           impedance_fits={n: "fit"})


def test_record_score_is_the_mean_log_misfit_of_the_rotating_records() -> None:
    # ln e = 1, ln e^3 = 3 -> 2 (the standstill fit is not counted, the reports not read)
    assert record_score(_fake(4, [math.e, math.e**3])) == pytest.approx(2.0, rel=1e-12)
    assert record_score(_fake(4, [])) is None
    assert record_score(_fake(4, [2.0, float("nan")])) is None


def test_record_score_of_a_real_identification_matches_its_lubricant_stage(
        bench: Path) -> None:
    """Without a joint stage the score is the lubricant stage's reduced chi-square (which
    divides by m - n and adds the prior's rows: within 1 %); with a kept joint stage the
    speed's report is the joint fit's and differs, the score still measures the record."""
    data = read_dataset(bench)
    plain = identify(data, sections=(2,), max_nfev=12)
    rep = next(f.report for f in plain.speeds if f.state == "rotating")
    assert rep is not None and rep.name.startswith("lubricant")
    score = record_score(plain)
    assert score is not None
    assert math.exp(score) == pytest.approx(rep.chi2_red, rel=0.01)


def test_neighbours_stay_within_the_candidates() -> None:
    assert neighbour_sections(4, (2, 3, 4, 5, 6)) == [3, 5]
    assert neighbour_sections(6, (2, 3, 4, 5, 6)) == [5]
    assert neighbour_sections(2, (2,)) == []


def test_the_count_with_the_best_record_fit_is_kept() -> None:
    calls: list[tuple[tuple[int, ...], dict[str, Any]]] = []
    chi = {4: [20.0, 20.0], 3: [25.0, 30.0], 5: [14.0, 14.0]}

    def run(dataset: Any, effects: Any, *, sections: Any, **kw: Any) -> Any:
        calls.append((tuple(sections), kw))
        n = 4 if len(sections) > 1 else sections[0]  # the spectra choose 4
        return _fake(n, chi[n])

    ds: Any = "ds"
    got, scores = identify_by_records(ds, ("e",), sections=(2, 3, 4, 5, 6), run=run,
                                      max_nfev=7)
    assert got.spec.n_sections == 5
    assert scores == pytest.approx({3: math.log(math.sqrt(750.0)), 4: math.log(20.0),
                                    5: math.log(14.0)}, rel=1e-12)
    # the spectra's run sees every candidate, each neighbour only its own count, the same
    # settings and the recordings prepared by the first run
    assert [c[0] for c in calls] == [(2, 3, 4, 5, 6), (3,), (5,)]
    assert all(c[1]["max_nfev"] == 7 for c in calls)
    assert "prepared" not in calls[0][1]
    assert calls[1][1]["prepared"] == {0.0: "p0", 100.0: 0, 200.0: 1}
    assert calls[1][1]["impedance_fits"] == {4: "fit"}  # the first run's impedance stages


def test_reused_impedance_fits_give_the_same_identification(bench: Path) -> None:
    """A count whose impedance stage was fitted before (``impedance_fits``) is not fitted
    again and the identification is the one fitting it anew gives (the stages are
    independent of each other); the first run returns every count it fitted."""
    data = read_dataset(bench)
    first = identify(data, sections=(2, 3), max_nfev=6, max_nfev_lubricant=4)
    assert sorted(first.impedance_fits) == [2, 3]
    other = 5 - first.spec.n_sections
    anew = identify(data, sections=(other,), max_nfev=6, max_nfev_lubricant=4)
    reused = identify(data, sections=(other,), max_nfev=6, max_nfev_lubricant=4,
                      impedance_fits=first.impedance_fits)
    assert reused.stages[0].nfev == anew.stages[0].nfev
    for name in anew.params.names:
        assert reused.params[name] == pytest.approx(anew.params[name], rel=1e-9), name
    imp = [s for s in reused.stages if s.name.startswith("impedance")]
    assert imp[0] is first.impedance_fits[other][1]  # taken, not fitted again


def test_without_rotating_records_the_spectra_choice_stands() -> None:
    n_calls = []

    def run(dataset: Any, effects: Any, *, sections: Any, **kw: Any) -> Any:
        n_calls.append(1)
        return _fake(4, [])

    ds: Any = "ds"
    got, scores = identify_by_records(ds, (), sections=(3, 4, 5), run=run)
    assert got.spec.n_sections == 4 and scores == {4: None} and len(n_calls) == 1


def test_reproduce_refuses_an_unknown_choice() -> None:
    # checked before the data: an empty dataset is not what is reported
    with pytest.raises(InputError, match="sections_by"):
        reproduce(Dataset(name="empty", impedance={}),
                  sections_by="coils")  # type: ignore[arg-type]


def test_cli_records_choice_end_to_end(bench: Path, tmp_path: Path) -> None:
    """Two candidate counts on the small bench: both are identified, their scores are in
    results.json and the count kept is the one with the lower score."""
    out = tmp_path / "out"
    code = main(["reproduce", str(bench), "--out", str(out), "--sections", "2,3",
                 "--sections-by", "records", "--max-nfev", "12", "--max-nfev-lubricant",
                 "12", "--lubricant-random-starts", "0", "--no-blackbox", "--quiet"])
    assert code == 0
    model = json.loads((out / "results.json").read_text())["model"]
    assert model["sections_by"] == "records"
    scores = {int(k): v for k, v in model["section_scores"].items()}
    assert set(scores) == {2, 3}
    assert all(v is not None and math.isfinite(v) for v in scores.values())
    assert model["n_sections"] == min(scores, key=lambda k: scores[k])
    assert "Section count chosen by the rotating records" in (out / "report.html").read_text()
