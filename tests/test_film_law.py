"""The film law across speeds of the PMSM detective (``diagnose --film-law``,
:mod:`vfmodel.detective.film_law`).

References: the power law itself (per-speed values computed by hand), synthetic per-speed
values of known exponents, central differences of the network solved directly (sparse LU),
and the free per-speed family's own analytic Jacobian.
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

import vfmodel.detective.pmsm as pmsm
from tests.conftest import REPO
from vfmodel.circuit import transfer
from vfmodel.cli.main import main
from vfmodel.core.io_dataset import read_dataset
from vfmodel.detective.film_law import (
    FilmLaw,
    exp_name,
    ref_name,
    speed_tag,
)
from vfmodel.detective.fit import evaluate
from vfmodel.errors import InputError
from vfmodel.greybox.assembly import default_params, lubricant_names

CASE = REPO / "data" / "concealed" / "pmsm_null"     # recordings at 0, 100 and 300 rpm
SPEEDS = (100.0, 300.0)


def _law_params(law: FilmLaw, speeds: tuple[float, ...]) -> Any:
    """Default parameters with per-speed copies and the law's parameters."""
    p = pmsm._with_speed_copies(default_params(), speeds)
    return p.with_specs(law.specs(p))


def test_per_speed_values_follow_the_power_law_exactly() -> None:
    law = FilmLaw((0.0, 100.0, 200.0, 500.0))
    assert law.speeds == (100.0, 200.0, 500.0)
    assert law.n_ref == pytest.approx((100 * 200 * 500) ** (1 / 3), rel=1e-14)
    p = _law_params(law, law.speeds).with_values({
        ref_name("lubricant.C_1"): 3e-9, exp_name("lubricant.C_1"): math.exp(0.4),
        ref_name("lubricant.R_1"): 2e4, exp_name("lubricant.R_1"): math.exp(1.3),
        "lubricant.tau_d": 2e-6, "lubricant.k_d": 0.3})
    fam = SimpleNamespace(law=law)
    for s in law.speeds:
        ps = pmsm.PmsmFamily.at_speed(fam, p, s)  # type: ignore[arg-type]
        x = s / law.n_ref
        assert ps["lubricant.C_1"] == pytest.approx(3e-9 * x**-0.4, rel=1e-13)
        assert ps["lubricant.R_1"] == pytest.approx(2e4 * x**1.3, rel=1e-13)
        assert ps["lubricant.tau_d"] == pytest.approx(2e-6, rel=1e-13)
        assert ps["lubricant.k_d"] == pytest.approx(0.3, rel=1e-13)
        # not governed: the per-speed copy
        assert ps["bearing.C_edge"] == p["bearing.C_edge" + speed_tag(s)]
        # realise writes the same values into the copies
        q = law.realise(p)
        assert q["lubricant.C_1" + speed_tag(s)] == pytest.approx(ps["lubricant.C_1"],
                                                                 rel=1e-13)
    # the standstill network keeps its base values
    assert pmsm.PmsmFamily.at_speed(fam, p, 0.0) is p  # type: ignore[arg-type]


def test_start_recovers_known_exponents() -> None:
    """Synthetic per-speed values (4 speeds) of C_1 ~ n^-0.37, R_1 ~ n^1.21 with a
    deterministic wobble of zero sum and zero slope in ln n: the least-squares law gives
    the exponents and the geometric-mean reference to 1e-12; an exponent beyond its bound
    (C_1 ~ n^-1.5, bound 1) is clipped to the bound."""
    speeds = (100.0, 200.0, 400.0, 800.0)
    law = FilmLaw(speeds)
    t = np.log(np.asarray(speeds) / law.n_ref)
    wob = np.array([0.01, -0.01, -0.01, 0.01])      # orthogonal to 1 and to t
    assert abs(wob @ t) < 1e-15
    p = _law_params(law, speeds)
    vals = {}
    for i, s in enumerate(speeds):
        vals["lubricant.C_1" + speed_tag(s)] = 5e-9 * math.exp(-0.37 * t[i] + wob[i])
        vals["lubricant.R_1" + speed_tag(s)] = 3e4 * math.exp(1.21 * t[i] - wob[i])
        vals["lubricant.tau_d" + speed_tag(s)] = 1e-6 * math.exp(wob[i])
    st = law.start(p.with_values(vals))
    assert math.log(st[exp_name("lubricant.C_1")]) == pytest.approx(0.37, abs=1e-12)
    assert math.log(st[exp_name("lubricant.R_1")]) == pytest.approx(1.21, abs=1e-12)
    assert st[ref_name("lubricant.C_1")] == pytest.approx(5e-9, rel=1e-12)
    assert st[ref_name("lubricant.R_1")] == pytest.approx(3e4, rel=1e-12)
    assert st["lubricant.tau_d"] == pytest.approx(1e-6, rel=1e-12)
    steep = {"lubricant.C_1" + speed_tag(s): 5e-9 * math.exp(-1.5 * t[i])
             for i, s in enumerate(speeds)}
    st2 = law.start(p.with_values(steep))
    assert math.log(st2[exp_name("lubricant.C_1")]) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("speeds", [(0.0, 100.0), (0.0,), (100.0, 100.0)])
def test_one_rotating_speed_is_refused(speeds: tuple[float, ...]) -> None:
    with pytest.raises(InputError, match="two or more rotating speeds"):
        FilmLaw(speeds)


def test_cli_film_law_with_one_rotating_speed(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    """``diagnose --film-law`` on a dataset with recordings at 0 and 100 rpm: one message,
    exit 2, no traceback (refused before the identification)."""
    ds = tmp_path / "one_speed"
    shutil.copytree(CASE, ds)
    toml = (ds / "dataset.toml").read_text()
    head, _, _ = toml.partition('[[recording]]\nspeed_rpm = 300.0')
    (ds / "dataset.toml").write_text(head)
    assert [r.speed_rpm for r in read_dataset(ds).recordings] == [0.0, 100.0]
    code = main(["diagnose", str(ds), "--film-law", "--out", str(tmp_path / "out"), "-q"])
    err = capsys.readouterr().err
    assert code == 2
    assert "two or more rotating speeds" in err and "Traceback" not in err


@pytest.fixture(scope="module")
def law_family() -> pmsm.PmsmFamily:
    """The PMSM family of ``pmsm_null`` with the film law, its staged identification
    replaced by default values with per-speed films of known trend (the data are only the
    reference of the residual here; ~15 s instead of ~30 s)."""
    p0 = default_params()

    def fake_identify(dataset: Any, effects: Any, **kw: Any) -> Any:
        lub = lubricant_names(p0)
        speeds = [SimpleNamespace(speed_rpm=s, params=p0.with_values(
            {n: p0[n] * (s / 100) ** (0.3 if "R_" in n else -0.2) for n in lub},
            clip=True)) for s in SPEEDS]
        return SimpleNamespace(params=p0, speeds=speeds,
                               spec=SimpleNamespace(n_sections=2))

    mp = pytest.MonkeyPatch()
    mp.setattr(pmsm, "identify", fake_identify)
    try:
        return pmsm.pmsm_family(read_dataset(CASE), film_law=True, sections=(2,))
    finally:
        mp.undo()


def test_law_jacobian_is_speed_jacobian_times_a(law_family: pmsm.PmsmFamily,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """The law's analytic Jacobian equals the free per-speed family's Jacobian at the
    realised values times A (to 1e-12 of its norm: the same numbers, one matrix product),
    and its law columns (the exponents, a constant) match central differences of the
    network solved directly (step 1e-4 in x; 2 % of the column norm, the tolerance of the
    free family's test in test_detective_pmsm.py: adjoint sensitivities interpolated over
    the record bins)."""
    fam = law_family
    p = fam.start
    names = fam.free_names((), p)
    law_cols = [k for k, n in enumerate(names) if "~" in n or n in ("lubricant.tau_d",
                                                                    "lubricant.k_d")]
    assert [names[k] for k in law_cols] == [
        "lubricant.R_1~ref", "lubricant.R_1~exp", "lubricant.C_1~ref", "lubricant.C_1~exp",
        "lubricant.k_d", "lubricant.tau_d"]
    assert not any("lubricant.C_1@" in n or "lubricant.tau_d@" in n for n in names)
    r, jm = fam.residual_jacobian((), p, names)
    np.testing.assert_allclose(r, evaluate(fam, (), p), rtol=0, atol=1e-9)
    net, a = fam.law.expand(names, p)  # type: ignore[union-attr]
    free = fam.free_description()
    pr = fam.law.realise(p)  # type: ignore[union-attr]
    r2, js = free.residual_jacobian((), pr, net)
    np.testing.assert_allclose(r2, r, rtol=0, atol=1e-9)
    assert np.linalg.norm(jm - js @ a) <= 1e-12 * np.linalg.norm(jm)
    monkeypatch.setattr(transfer, "transfer_on",
                        lambda mna, b, cout, v, f: mna.solve(f, b, cout, v, method="sparse").h)
    h = 1e-4
    for k in (law_cols[1], law_cols[3], law_cols[5]):      # both exponents and tau_d
        x = p.to_log(names)
        x[k] += h
        rp = evaluate(fam, (), p.from_log(x, names))
        x[k] -= 2 * h
        rm = evaluate(fam, (), p.from_log(x, names))
        fd = (rp - rm) / (2 * h)
        big = float(np.linalg.norm(fd))
        assert big > 0, names[k]
        assert np.linalg.norm(fd - jm[:, k]) <= 0.02 * big, (names[k],
                                                            np.linalg.norm(fd - jm[:, k]) / big)


def test_free_description_has_the_per_speed_names(law_family: pmsm.PmsmFamily) -> None:
    """Free per-speed description of the same family: the law's parameters are gone and
    each governed name has a copy per speed. pmsm_null's starting network has the metallic
    contact (base film not fitted), 8 speed-dependent names at 2 speeds: 16 free copies;
    the law: 4 power-law + 2 constants + 4 x 2 copies = 14."""
    p = law_family.start
    free = law_family.free_description()
    assert free.law is None and law_family.law is not None
    fn = free.free_names((), p)
    ln = law_family.free_names((), p)
    assert not any("~" in n for n in fn)
    for s in SPEEDS:
        for n in ("lubricant.C_1", "lubricant.R_1", "lubricant.k_d", "lubricant.tau_d"):
            assert n + speed_tag(s) in fn and n + speed_tag(s) not in ln
    assert sum("@" in n for n in fn) == 16
    assert sum("@" in n or "~" in n for n in ln) == 12
    assert {"lubricant.k_d", "lubricant.tau_d"} <= set(ln) - set(fn)
    assert len(fn) - len(ln) == 2


def test_unrecorded_speed_follows_the_law_and_the_recorded_trend() -> None:
    """At a speed that was not recorded: the governed values from the law (computed by
    hand), a value free per speed from the power law through its copies (copies made
    with a known exponent: recovered to rounding), the constants as they are."""
    law = FilmLaw((0.0, 100.0, 200.0, 500.0))
    p = _law_params(law, law.speeds).with_values({
        ref_name("lubricant.C_1"): 3e-9, exp_name("lubricant.C_1"): math.exp(0.4),
        ref_name("lubricant.R_1"): 2e4, exp_name("lubricant.R_1"): math.exp(1.3),
        "lubricant.tau_d": 2e-6, "lubricant.k_d": 0.3,
        **{"bearing.C_edge" + speed_tag(s): 5e-10 * (s / 100) ** -0.25 for s in law.speeds},
        **{"lubricant.R_2" + speed_tag(s): 300.0 * (s / 100) ** 0.5 for s in law.speeds}})
    fam = SimpleNamespace(law=law)
    for rpm in (50.0, 1000.0, 333.0):
        ps = pmsm.PmsmFamily.at_speed(fam, p, rpm)  # type: ignore[arg-type]
        x = rpm / law.n_ref
        assert ps["lubricant.C_1"] == pytest.approx(3e-9 * x**-0.4, rel=1e-12)
        assert ps["lubricant.R_1"] == pytest.approx(2e4 * x**1.3, rel=1e-12)
        assert ps["lubricant.k_d"] == pytest.approx(0.3, rel=1e-12)
        assert ps["bearing.C_edge"] == pytest.approx(5e-10 * (rpm / 100) ** -0.25, rel=1e-9)
        assert ps["lubricant.R_2"] == pytest.approx(300.0 * (rpm / 100) ** 0.5, rel=1e-9)
    # a recorded speed keeps its copies
    at_200 = pmsm.PmsmFamily.at_speed(fam, p, 200.0)  # type: ignore[arg-type]
    assert at_200["bearing.C_edge"] == p["bearing.C_edge" + speed_tag(200.0)]


def test_recordings_at_other_speeds_are_recommended_with_the_law(
        law_family: pmsm.PmsmFamily) -> None:
    """With the law, a recording at half the lowest and twice the highest rotating speed
    is offered (pmsm_null: 100 and 300 rpm -> 50 and 600); its separation is the whitened
    difference of the two networks' u_B transfers there: 0 for the same network, > 0 for a
    film twice as thick (C_1 halved). Without the law it is not offered."""
    from vfmodel.detective.recommend import Comparison, Net, _separations, recommend

    p = law_family.start
    thick = p.with_values({ref_name("lubricant.C_1"): 0.5 * p[ref_name("lubricant.C_1")]})
    f = np.geomspace(1e3, 1e7, 11)
    same = _separations(law_family, Net((), p), Net((), p), (), 0.005, f)
    other = _separations(law_family, Net((), thick), Net((), p), (), 0.005, f)
    new = {k for k in other if k[0] == "recording:speed"}
    assert new == {("recording:speed", 50.0), ("recording:speed", 600.0)}
    for k in new:
        assert same[k][0] == 0.0 and other[k][0] > 1.0, (k, same[k][0], other[k][0])
        assert "film law" in other[k][3]
    # the ranked list keeps the more separating of the two; without the law none
    recs = recommend(law_family, [Comparison(("y",), Net((), thick), Net((), p), 1)])
    best = [r for r in recs if r.measurement == "recording:speed"]
    assert len(best) == 1 and best[0].expected_delta_chi2 == max(other[k][0] for k in new)
    free = recommend(law_family.free_description(),
                     [Comparison(("y",), Net((), thick), Net((), p), 1)])
    assert not any(r.measurement == "recording:speed" for r in free)


def test_film_law_with_a_user_model_is_refused() -> None:
    """The law is one of the PMSM model's lubricant film: with ``--model`` one message."""
    from vfmodel.pipeline.diagnose import run_diagnose

    with pytest.raises(InputError, match="--film-law: applies to the PMSM model"):
        run_diagnose(REPO / "data" / "concealed" / "rc_null", film_law=True,
                     model=REPO / "data" / "user-models" / "rc_ladder.net")


def test_sentence_and_report_name_the_supported_description() -> None:
    """The sentence says which description the data support and flags an exponent whose
    std exceeds half its bound range; the report shows it under the detective's sentence."""
    from vfmodel.pipeline.diagnose import film_law_sentence
    from vfmodel.report.diagnose_html import diagnose_html

    cmp = {"law": {"chi2": 100.0, "k": 4, "bic": 120.0, "chi2_red": 1.0},
           "free": {"chi2": 99.0, "k": 6, "bic": 129.0, "chi2_red": 1.01},
           "n_residuals": 104, "delta_bic_law_minus_free": -9.0, "supported": "law",
           "strength": "weak"}
    doc = {"n_ref_rpm": 173.2, "comparison": cmp, "power": {
        "lubricant.C_1": {"exponent": -0.15, "exponent_std": 0.1, "determined": True},
        "lubricant.R_1": {"exponent": 0.9, "exponent_std": 2.0, "determined": False}}}
    s = film_law_sentence(doc)
    assert "support the film law (weak" in s and "Delta BIC -9.0" in s
    assert "C_1 ~ speed^-0.15 (std 0.1)" in s
    assert "R_1 ~ speed^+0.90 (std 2, not determined by the data)" in s
    cmp2 = {**cmp, "supported": "free", "delta_bic_law_minus_free": 30.0,
            "strength": "very strong"}
    assert "support free per-speed film values (very strong" in film_law_sentence(
        {**doc, "comparison": cmp2})
    html = diagnose_html({"sentence": "S.", "film_law": {"sentence": s}}, [])
    assert "support the film law" in html
    assert "support the film law" not in diagnose_html({"sentence": "S."}, [])
