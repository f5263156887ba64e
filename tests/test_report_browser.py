"""The three reports in a real browser (headless Chromium over the DevTools protocol).

Each report is built from a small stored document and small figures (``reproduce``,
``diagnose``) or by the ``fit`` command on a small spectrum, opened in Chromium at
1280x800, and checked: no console error, no request to the network, no broken image, the
summary (verdict and checks table) and the key figure in the first screen, the zoom
overlay opens, and every number the page shows from the document (``span.num[data-key]``)
reads back (:func:`vfmodel.report.units.parse_si`) to the document's value. A screenshot
of the first screen is saved (into ``VFMODEL_SCREENSHOTS`` when set, else the test's
temporary folder).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import pytest

from tests._cdp import PAGE_FACTS_JS, browser, chromium_path
from tests._report_data import diagnose_document, reproduce_results, write_png
from vfmodel.report.units import parse_si, si

pytestmark = pytest.mark.skipif(
    chromium_path() is None and not os.environ.get("CI"),
    reason="Chromium not installed ('make test' installs the Debian package chromium)")


def _shots(tmp_path: Path) -> Path:
    d = Path(os.environ.get("VFMODEL_SCREENSHOTS") or tmp_path)
    d.mkdir(parents=True, exist_ok=True)
    return d


def _lookup(doc: Any, key: list[str]) -> Any:
    for k in key:
        doc = doc[int(k)] if isinstance(doc, list) else doc[k]
    return doc


def _open_and_check(tmp_path: Path, page: Path, doc: dict[str, Any], name: str
                    ) -> dict[str, Any]:
    with browser(tmp_path / "profile") as b:
        load = b.load(page)
        facts = b.evaluate(PAGE_FACTS_JS)
        shot = b.screenshot(_shots(tmp_path) / f"report_{name}_first_screen.png")
        zoom = b.evaluate("(() => { document.querySelector('#summary img').click(); "
                          "return getComputedStyle(document.getElementById('zoom')).display;"
                          "})()")
    assert load.console_errors == []
    assert [u for u in load.requests if not u.startswith(("file:", "data:"))] == []
    assert facts["external"] == []
    assert facts["n_images"] >= 1 and facts["broken"] == []
    vw, vh = facts["viewport"]
    assert (vw, vh) == (1280, 800)
    # the summary opens the page: verdict, checks table and key figure in the first screen
    assert facts["summary"]["top"] < 60
    assert facts["summary_table"]["bottom"] <= vh
    assert facts["key_image"]["top"] < vh and facts["key_image"]["height"] > 200
    assert facts["key_image_size"][0] > 300
    assert zoom == "block"
    assert shot.stat().st_size > 10_000
    # the page's numbers are the document's
    assert len(facts["numbers"]) >= 10
    for n in facts["numbers"]:
        shown = parse_si(n["text"], n["unit"]) / n["scale"]
        want = _lookup(doc, n["key"])
        assert shown == pytest.approx(want, rel=5e-3, abs=1e-12 * abs(want) + 1e-300), n
    return facts


def test_reproduce_report_in_chromium(tmp_path: Path) -> None:
    from vfmodel.report.html import write_reproduce_html

    res = reproduce_results()
    figs = [write_png(tmp_path / "fig20_22_bearing_300rpm.png", "bearing voltage at 300 rpm",
                      "waveform"),
            write_png(tmp_path / "fig19_impedance_cm.png", "CM impedance"),
            write_png(tmp_path / "fig23_lubricant.png", "lubricant film")]
    (tmp_path / "results.json").write_text(json.dumps(res))
    write_reproduce_html(tmp_path / "report.html", res, figs)
    doc = json.loads((tmp_path / "results.json").read_text())
    facts = _open_and_check(tmp_path, tmp_path / "report.html", doc, "reproduce")
    text = facts["text"]
    # headline figures visible as text, in engineering units
    assert si(doc["impedance"]["mean_mape_pct"], "%") in text
    assert si(doc["model"]["divider_intervals"]["c_wr_f"]["value"], "F") == "605.5 pF"
    assert "605.5 pF" in text and "188.6 pF" in text          # C_wr,div vs insulation.C_wr
    assert "C_wr,div = 3 (1 + insulation.k_d) insulation.C_wr" in text
    assert "not determined by the data" in text
    # missed: rotating mean and worst speed (300 rpm), spectral corr. at 0 rpm, BVR better
    assert "3 of 7 goals met" in facts["verdict"]
    keys = {tuple(n["key"]) for n in facts["numbers"]}
    assert ("model", "params", "insulation.C_wr") in keys
    assert ("bearing", "300", "lubricant_interval", "r_ohm", "hi") in keys


def test_diagnose_report_in_chromium(tmp_path: Path) -> None:
    from vfmodel.report.diagnose_html import write_diagnose_html

    doc = diagnose_document()
    figs = [write_png(tmp_path / "residual_impedance_Zin.png", "residuals Zin"),
            write_png(tmp_path / "overlay_impedance_Zin.png", "overlay Zin")]
    write_diagnose_html(tmp_path / "report.html", doc, figs)
    facts = _open_and_check(tmp_path, tmp_path / "report.html", doc, "diagnose")
    assert "1 of 1 goals met" in facts["verdict"]
    assert "2.155 → 0.9804" in facts["text"]
    assert "2.843 µs" in facts["text"]                        # tau_d with its SI prefix
    assert "not determined by the data" in facts["text"]      # its std of log is 1.42


def test_fit_report_in_chromium(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from tests._adversarial import run_cli, z_csv

    spec = tmp_path / "z.csv"
    spec.write_text(z_csv(41))
    out = tmp_path / "o"
    res = run_cli(capsys, ["fit", str(spec), "--order", "4", "--passive", "--out", str(out)])
    assert res.code == 0, res.err
    doc = json.loads((out / "model.json").read_text())
    facts = _open_and_check(tmp_path, out / "report.html", doc, "fit")
    assert facts["verdict"].endswith("goals met")
    assert si(doc["rel_rms_error"]) in facts["text"]
