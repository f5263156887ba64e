"""The winding's discretisation chosen with the rotating records, not the spectra alone.

:func:`vfmodel.greybox.identify.identify` picks the number of winding sections per phase
from the impedance spectra (the next candidate while the spectra's reduced chi-square still
falls by ``min_gain``). The count adds no parameters (the per-phase totals are the same for
every count), but it shapes the winding's common-mode resonance that the bearing voltage
rides on, and the spectra do not tell the counts apart well enough for that: on
independent bench 212 (issue 19) the spectra's chi2_red were 16.9 / 17.1 / 19.0 for 4 / 5 /
6 sections and they chose 4, while the rotating peaks were 1.51 / 0.73 / 0.42 % off on
average.

:func:`identify_by_records` runs the identification with the spectra's choice and with
its neighbours (one section fewer and one more, within the candidates) and keeps the one
whose rotating records are fitted best: the lowest mean of ``ln chi2_red`` over the
rotating speeds' stages (:func:`record_score`; the same records, noise model and
weights for every count, so the scores compare). Measured in session 25 (docs/notes.md):
on benches 103, 131, 203 and 212 this score picked the count with the lowest mean
rotating peak error every time. It costs an identification per neighbour.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from typing import Any, Literal

from vfmodel.core.dataset import Dataset
from vfmodel.greybox.identify import Identification, identify

__all__ = ["SectionsBy", "identify_by_records", "neighbour_sections", "record_score"]

SectionsBy = Literal["spectra", "records"]
"""How the winding-section count is chosen: by the impedance spectra alone
(:func:`~vfmodel.greybox.identify.identify`) or by the rotating records among the spectra's
choice and its neighbours (:func:`identify_by_records`)."""


def record_score(ident: Identification) -> float | None:
    """Mean ``ln chi2_red`` of the rotating speeds' stages; None without rotating records
    (or with a stage report missing or non-positive)."""
    chi = [f.report.chi2_red for f in ident.speeds
           if f.state == "rotating" and f.report is not None]
    if not chi or not all(math.isfinite(c) and c > 0 for c in chi):
        return None
    return sum(math.log(c) for c in chi) / len(chi)


def neighbour_sections(chosen: int, candidates: Sequence[int]) -> list[int]:
    """One section fewer and one more than ``chosen``, those among ``candidates``."""
    return [n for n in (chosen - 1, chosen + 1) if n in set(candidates)]


def identify_by_records(
    dataset: Dataset, effects: Iterable[str], *, sections: Sequence[int],
    run: Callable[..., Identification] = identify, **kw: Any,
) -> tuple[Identification, dict[int, float | None]]:
    """The identification whose winding-section count fits the rotating records best
    (module docstring) and the score of every count tried (``{sections: score}``).

    ``kw`` goes to ``run`` (:func:`~vfmodel.greybox.identify.identify`) unchanged; the
    recordings are prepared once. Without rotating records the spectra's choice is
    returned alone.
    """
    eff = tuple(effects)
    first = run(dataset, eff, sections=sections, **kw)
    scores: dict[int, float | None] = {first.spec.n_sections: record_score(first)}
    if scores[first.spec.n_sections] is None:
        return first, scores
    prepared = {f.speed_rpm: f.term.prep for f in first.speeds}
    best, best_score = first, scores[first.spec.n_sections]
    for n in neighbour_sections(first.spec.n_sections, sections):
        got = run(dataset, eff, sections=(n,), **{**kw, "prepared": prepared})
        scores[n] = s = record_score(got)
        if s is not None and best_score is not None and s < best_score:
            best, best_score = got, s
    return best, dict(sorted(scores.items()))
