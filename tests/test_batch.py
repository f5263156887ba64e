"""``vfmodel batch``: jobs on a Dask LocalCluster and on local processes, results identical
to single runs, a broken input reported without stopping the others, the summaries."""

from __future__ import annotations

import csv
import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests._adversarial import run_cli
from tests.conftest import load_script

ROOT = Path(__file__).resolve().parents[1]
FILES = [ROOT / "data" / "vfbench" / "cpw.s2p",
         ROOT / "data" / "vfbench" / "circuit_vi_Coaxial_T.s3p"]


@pytest.fixture(scope="module")
def cluster() -> Any:
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=":0") as c, distributed.Client(c) as cl:
        yield cl


def _broken(tmp: Path) -> Path:
    p = tmp / "broken.s2p"
    p.write_text("! not a Touchstone file\n# GHz S MA R 50\n1 0.5 nonsense\n")
    return p


def _model(path: Path) -> dict[str, Any]:
    return dict(json.loads(path.read_text()))


def _same_model(a: dict[str, Any], b: dict[str, Any]) -> None:
    assert a.keys() == b.keys()
    for k in ("poles", "residues", "d", "e", "rel_rms_error"):
        np.testing.assert_allclose(np.asarray(a[k], float), np.asarray(b[k], float),
                                   rtol=1e-10, atol=1e-12 * float(np.max(np.abs(a[k]))))
    assert a["passive"] == b["passive"] and a["order_reason"] == b["order_reason"]


def _rows(out: Path) -> dict[str, dict[str, str]]:
    with (out / "batch_summary.csv").open() as f:
        return {r["job"]: r for r in csv.DictReader(f)}


def test_batch_fit_on_a_local_cluster(tmp_path: Path, cluster: Any,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    from vfmodel.cli.cmd_batch import run

    out = tmp_path / "batch"
    inputs = (*FILES, _broken(tmp_path))
    code = run("fit", inputs, out, ("--order", "auto"), None, None, True, client=cluster)
    assert code == 1                                        # one job failed
    rows = _rows(out)
    assert [rows[n]["status"] for n in ("cpw", "circuit_vi_Coaxial_T", "broken")] == [
        "ok", "ok", "FAILED"]
    assert "line 3" in rows["broken"]["error"]
    assert "broken failed" in capsys.readouterr().err
    page = (out / "batch_summary.html").read_text()
    assert "2 of 3" in page and "FAILED" in page
    # identical to a single run of the same command
    for p in FILES:
        single = tmp_path / f"single_{p.stem}"
        with warnings.catch_warnings():   # as from a shell (cpw.s2p warns: FitWarning)
            warnings.simplefilter("default")
            res = run_cli(capsys, ["fit", str(p), "--out", str(single), "--quiet"])
        assert res.code == 0, res.err
        _same_model(_model(out / p.stem / "model.json"), _model(single / "model.json"))
        assert float(rows[p.stem]["rel_rms_error"]) == pytest.approx(
            _model(single / "model.json")["rel_rms_error"], rel=1e-10)
        assert (out / p.stem / "report.html").is_file()


def test_batch_reproduce_on_a_local_cluster(tmp_path: Path, cluster: Any) -> None:
    from vfmodel.cli.cmd_batch import run

    ds = tmp_path / "ds"   # the small bench of test_reproduce
    load_script("make_testbench").make_bench(ds, seed=2, speeds=(0.0, 200.0), periods=1,
                                             n_freq=81, n_coils=2, n_rungs=4)
    out = tmp_path / "batch"
    code = run("reproduce", (ds, tmp_path / "missing"), out,
               ("--max-nfev", "6", "--sections", "2", "--no-blackbox"), None, None, True,
               client=cluster)
    assert code == 1
    rows = _rows(out)
    assert rows["ds"]["status"] == "ok" and rows["missing"]["status"] == "FAILED"
    r = json.loads((out / "ds" / "results.json").read_text())
    assert float(rows["ds"]["mean_mape_pct"]) == pytest.approx(
        r["impedance"]["mean_mape_pct"], rel=1e-12)


def test_batch_cli_local_processes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "b"
    res = run_cli(capsys, ["batch", "fit", str(FILES[0]), str(_broken(tmp_path)),
                           "--workers", "2", "--out", str(out), "--quiet"])
    assert res.code == 1
    assert "some jobs of the batch failed" in res.err
    assert _rows(out)["cpw"]["status"] == "ok"
    res = run_cli(capsys, ["batch", "fit", str(FILES[0]), "--out", str(tmp_path / "c"),
                           "--quiet"])
    assert res.code == 0, res.err
    assert "1 of 1 fit jobs succeeded" in res.out
