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
whose rotating records are fitted best (:func:`record_score`: the mean over the rotating
speeds of ``ln`` of the final model's reduced record misfit; the same records, noise model
and weights for every count, so the scores compare). Measured in session 25 on the 17
independent benches of session 24 (docs/notes.md): mean rotating peak error 1.10 -> 0.88 %,
worst speed 6.52 -> 4.70 %, better on eight benches, worse on three (201, 210, 211). On six
fresh benches (session 26, seeds 220-225): 1.08 -> 1.10 %, better on one, worse on two, and
one standstill correlation 0.9326 (the score counts only the rotating records). With that
and an identification per neighbour (the impedance stages are reused), it is not the
default.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np

from vfmodel._choices import SectionsBy
from vfmodel.core.dataset import Dataset
from vfmodel.greybox.identify import Identification, identify

__all__ = ["SectionsBy", "identify_by_records", "neighbour_sections", "record_score"]

def record_score(ident: Identification) -> float | None:
    """Mean over the rotating speeds of ``ln(sum r^2 / n)``, ``r`` the whitened residual of
    the speed's record term (its H1 term with ``rotating_fit="h1"``) at the speed's final
    values; None without rotating records or with a non-finite or zero misfit.

    The residuals are evaluated rather than read from the stage reports: after a kept joint
    stage every speed's report is the joint fit's (impedance spectra included), so the
    reports of two counts need not measure the same thing."""
    logs: list[float] = []
    for f in ident.speeds:
        if f.state != "rotating":
            continue
        term = f.record if f.record is not None else f.term
        r = np.asarray(term.residual(f.params)[0], dtype=float)
        chi = float(r @ r) / max(r.size, 1)
        if not (math.isfinite(chi) and chi > 0):
            return None
        logs.append(math.log(chi))
    return sum(logs) / len(logs) if logs else None


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
        got = run(dataset, eff, sections=(n,), **{**kw, "prepared": prepared,
                                                   "impedance_fits": first.impedance_fits})
        scores[n] = s = record_score(got)
        if s is not None and best_score is not None and s < best_score:
            best, best_score = got, s
    return best, dict(sorted(scores.items()))
