"""Near-lossless reflections that turn the wrong way (:mod:`vfmodel.fitting.foster`).

Reference: Foster's reactance theorem -- a lossless one-port's S11 turns clockwise (its
phase falls) with frequency. A short behind a delay tau, ``S11 = -exp(-j w 2 tau)``, obeys
it; the same with the delay's sign reversed (a reference plane beyond the short) does not.
"""

from __future__ import annotations

import numpy as np

from vfmodel.core.frequency_data import FrequencyData
from vfmodel.fitting.foster import backward_reflections
from vfmodel.pipeline.fit_job import run_fit

F_HZ = np.linspace(10e6, 6e9, 301)
TAU = 20e-12  # one-way delay of the offset


def _short(sign: float, loss: float = 1.0) -> FrequencyData:
    w = 2 * np.pi * F_HZ
    return FrequencyData(F_HZ, -loss * np.exp(sign * 1j * w * 2 * TAU), kind="S", z0=50.0)


def test_only_the_counter_clockwise_short_is_flagged() -> None:
    assert backward_reflections(_short(-1.0)) == []          # causal: phase falls
    flagged = backward_reflections(_short(+1.0))
    assert len(flagged) == 1 and flagged[0][0] == 0 and flagged[0][1] > 0.99
    # a matched-ish load (|S| 0.1) is not near-lossless: Foster does not apply
    assert backward_reflections(_short(+1.0, loss=0.1)) == []


def test_causal_short_enforced_within_its_bound_gets_no_note() -> None:
    # a causal short 5e-4 above |S| = 1 (a calibration error): the fit is not passive, the
    # enforcement runs and brings it to about the data floor, within 1.2x: no note
    ok = run_fit([_short(-1.0, loss=1.0005)], passive=True)
    floor = ok.data_passivity.floor if ok.data_passivity else 0.0
    assert floor > 4e-4                                   # the data are 5e-4 outside
    assert ok.passivity is not None and ok.passivity.passive
    assert ok.rel_rms_error > ok.unconstrained_rel_rms_error      # enforcement moved it
    assert ok.rel_rms_error <= 1.2 * max(ok.unconstrained_rel_rms_error, floor)
    assert not [n for n in ok.fit.notes if n.startswith("passivity enforcement left")]


def test_cli_prints_the_note_under_warnings_as_errors(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    # a passive causal model cannot turn counter-clockwise: the enforced model leaves the
    # data by far more than 1.2x max(fit error, data floor), and the note says why. pytest
    # runs with filterwarnings = error: the CLI must still print vfmodel's warnings (a
    # warning of the fit once became "internal error", exit 1)
    import json

    from tests._adversarial import run_cli

    s = _short(+1.0).values[:, 0, 0]
    rows = "\n".join(f"{f:.12g} {v.real:.15g} {v.imag:.15g}" for f, v in zip(F_HZ, s, strict=True))
    path = tmp_path / "short_beyond.s1p"
    path.write_text("# Hz S RI R 50\n" + rows + "\n")
    # no passive model comes near: the retries would run to the default time limit (94 s
    # of the suite); a short limit leaves the note to test
    res = run_cli(capsys, ["fit", str(path), "--passive", "--enforce-time-limit", "5",
                           "--out", str(tmp_path / "o")])
    assert res.code == 0, res.err
    assert "vfmodel: warning: passivity enforcement left the model" in res.err
    assert "counter-clockwise" in res.err
    doc = json.loads((tmp_path / "o" / "model.json").read_text())
    floor = doc["passivity"]["data_floor"] or 0.0
    assert doc["rel_rms_error"] > 1.2 * max(doc["passivity"]["unconstrained_rel_rms_error"],
                                            floor)
    assert any("turns counter-clockwise" in n for n in doc["fit_notes"])
