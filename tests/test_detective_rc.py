"""Detective on a non-machine network (RC ladder, data/user-models/rc_ladder.net) and its
building blocks (noise estimate, band location, user-model parser)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from vfmodel.cli.main import main
from vfmodel.detective.diagnose import Diagnosis, diagnose
from vfmodel.detective.locate import locate
from vfmodel.detective.noise import spectrum_noise
from vfmodel.detective.problem import Channel
from vfmodel.detective.user_model import (
    UserFamily,
    parse_user_model,
    read_user_model,
    user_family,
)
from vfmodel.errors import InputError
from vfmodel.pipeline.diagnose import diagnosis_json

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "data" / "user-models" / "rc_ladder.net"
CASES = ROOT / "data" / "concealed"


def _chan(n: int = 200) -> Channel:
    f = np.logspace(3, 7, n)
    return Channel("impedance:X", f, np.ones(n, complex), np.ones(n))


def test_locate_no_false_alarm_on_white_noise() -> None:
    # reference: residuals N(0, 1) -> family-wise false-alarm probability <= alpha = 1e-3
    ch = _chan()
    rng = np.random.default_rng(1)
    alarms = sum(bool(locate([ch], rng.standard_normal(400))) for _ in range(30))
    assert alarms == 0


def test_locate_finds_a_small_bias_band() -> None:
    # a bias of 1 noise std on points 100..163 of the real part: hidden point by point, but
    # the window mean over 64 points is 8 std: T = 64, chi2(2) tail 1.3e-14, times ~1800
    # tests -> corrected p ~ 2e-11, z > 6
    ch = _chan()
    r = np.random.default_rng(2).standard_normal(400)
    r[100:164] += 1.0
    mm = locate([ch], r)
    assert len(mm) == 1
    assert mm[0].where == "impedance:X"
    assert 75 <= mm[0].i0 <= 110 and 155 <= mm[0].i1 <= 190
    assert mm[0].significance > 6.0


def test_noise_estimate_of_a_noisy_spectrum() -> None:
    # reference: relative complex noise 0.004 |Z| (N + jN)/sqrt2 -> std of Re/Im log Z
    # = 0.004 / sqrt2 = 2.83e-3; the estimate must be within 15 %
    f = np.logspace(3, 7, 200)
    s = 2j * np.pi * f
    z = 100 + 1 / (s * 10e-9) + s * 1e-6
    rng = np.random.default_rng(3)
    zn = z * (1 + 0.004 * (rng.standard_normal(200) + 1j * rng.standard_normal(200)) / np.sqrt(2))
    nz = spectrum_noise(f, zn)
    assert nz.sigma == pytest.approx(0.004 / np.sqrt(2), rel=0.15)
    assert nz.sigma_second_difference == pytest.approx(0.004 / np.sqrt(2), rel=0.25)


def test_user_model_parser_and_errors() -> None:
    m = read_user_model(MODEL)
    assert m.params.names == ("R1", "C1", "R2", "C2", "R3", "C3")
    assert m.params["C2"] == pytest.approx(4.7e-9, rel=1e-12)
    assert [p[0] for p in m.ports] == ["Zin", "Zout"]
    assert ("insulation_dielectric_loss", "C2") in m.effects
    assert len(m.effects) == 10
    with pytest.raises(InputError, match="applies to a capacitor"):
        parse_user_model("R1 a 0 1 [0.1 10]\n.port P a 0\n.effect insulation_dielectric_loss R1")
    with pytest.raises(InputError, match="unknown parameter"):
        parse_user_model("R1 a 0 {q}\n.port P a 0")
    with pytest.raises(InputError, match="line 2"):
        parse_user_model("R1 a 0 1\nQ1 a 0 1\n.port P a 0")


def test_user_family_matches_the_analytic_rc_ladder() -> None:
    # reference: Z_in of the ladder by hand (series/parallel reduction)
    m = read_user_model(MODEL)
    f = np.logspace(3, 7, 50)
    ch = tuple(Channel(f"impedance:{p[0]}", f, np.ones(50, complex), np.ones(50))
               for p in m.ports)
    fam = UserFamily(m, ch, (1e3, 1e7))
    z_in = fam.predict((), m.params)[0]
    s = 2j * np.pi * f
    v = m.params.as_dict()

    def par(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return a * b / (a + b)

    z3 = v["R3"] + 1 / (s * v["C3"])
    z2 = v["R2"] + par(1 / (s * v["C2"]), z3)
    ref = v["R1"] + par(1 / (s * v["C1"]), z2)
    np.testing.assert_allclose(z_in, ref, rtol=1e-10)


@pytest.fixture(scope="module")
def concealed() -> tuple[UserFamily, Diagnosis]:
    fam = user_family(read_user_model(MODEL), CASES / "rc_dielectric_loss")
    return fam, diagnose(fam)


def test_concealed_dielectric_loss_is_found_at_c2(concealed: tuple[UserFamily, Diagnosis]
                                                  ) -> None:
    fam, d = concealed
    truth = json.loads((CASES / "rc_dielectric_loss" / "truth.json").read_text())
    assert d.mismatch_found
    assert [f.candidate.key for f in d.findings] == [("insulation_dielectric_loss", "C2")]
    f = d.findings[0]
    assert f.identifiable
    # chi2_red: before clearly above 1, after within 10 % of 1 (noise-limited fit)
    assert f.before.chi2_red > 1.5
    assert f.after.chi2_red == pytest.approx(1.0, abs=0.1)
    # the concealed parameters are recovered (truth k_d = 0.12, tau_d = 2.65 us)
    k_d = f.after.params["C2.insulation_dielectric_loss.k_d"]
    tau = f.after.params["C2.insulation_dielectric_loss.tau_d"]
    assert k_d == pytest.approx(truth["truth_params"]["C2.insulation_dielectric_loss.k_d"],
                                rel=0.2)
    assert tau == pytest.approx(truth["truth_params"]["C2.insulation_dielectric_loss.tau_d"],
                                rel=0.3)
    # every other candidate rejected with a reason
    assert len(d.rejected) == 9
    assert all(why for _, why in d.rejected)
    assert not d.remaining
    doc = diagnosis_json(fam, d)
    assert doc["mismatch_found"] is True
    assert doc["findings"][0]["after"]["chi2_red"] < doc["findings"][0]["before"]["chi2_red"]
    assert {"where", "band_hz", "significance"} <= set(doc["mismatches"][0])
    json.dumps(doc, allow_nan=False)


def test_heldout_scored_only_where_the_bic_supports(concealed: tuple[UserFamily, Diagnosis]
                                                    ) -> None:
    # the first round (a mismatch to explain): a held-out score exactly for the candidates
    # with Delta BIC < -10 (bic_min); the others are rejected without one
    _, d = concealed
    first = d.trials[0]
    assert any(t.delta_bic < -10 for t in first) and any(t.delta_bic >= -10 for t in first)
    for t in first:
        assert np.isfinite(t.heldout_delta_chi2) == (t.delta_bic < -10), t.candidate.key
    assert d.findings[0].trial.heldout_delta_chi2 < -2      # its 2 new parameters
    for c, why in d.rejected:
        if c.key in {t.candidate.key for t in first if t.delta_bic >= -10}:
            assert "held-out Delta" not in why, why


def test_null_case_is_clean() -> None:
    fam = user_family(read_user_model(MODEL), CASES / "rc_null")
    d = diagnose(fam)
    assert not d.mismatch_found
    assert d.findings == ()
    assert d.start.chi2_red == pytest.approx(1.0, abs=0.1)
    assert len(d.rejected) == 10


def test_cli_rejects_without_with_model(tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["diagnose", str(CASES / "rc_null"), "--model", str(MODEL),
                 "--without", "fixture_inductance", "--out", str(tmp_path / "o")])
    assert code == 2
    assert "--without" in capsys.readouterr().err
    assert not (tmp_path / "o" / "diagnosis.json").exists()
