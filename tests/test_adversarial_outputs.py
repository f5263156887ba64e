"""Adversarial suite, outputs and interruption: bad output places are refused at command
start, a command's outputs appear all together or not at all and never mixed with an
earlier run's, strict JSON, modes from the umask, Ctrl-C exits 130 without a traceback
(issue 16; harness in tests/_adversarial.py). Long jobs are replaced by fakes that fail
where the real job could."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from benches.small_dataset import make_small_dataset
from tests._adversarial import (
    GREYBOX_NETLIST,
    assert_refused,
    copy_tree,
    run_cli,
    snapshot,
    z_csv,
)

PYTHON = sys.executable


@pytest.fixture(scope="module")
def fit_result(tmp_path_factory: pytest.TempPathFactory) -> Any:
    from vfmodel.core.io_spectrum import read_spectrum
    from vfmodel.pipeline.fit_job import run_fit

    p = tmp_path_factory.mktemp("fit") / "z.csv"
    p.write_text(z_csv(41))
    return run_fit([read_spectrum(p)], order=4)


@pytest.fixture
def spectrum(tmp_path: Path) -> Path:
    p = tmp_path / "z.csv"
    p.write_text(z_csv(41))
    return p


@pytest.fixture
def fake_fit(monkeypatch: pytest.MonkeyPatch, fit_result: Any) -> None:
    """The fit job returns a stored result; fit.png is a stub written the way figures are
    (atomically; the real figure takes seconds and is tested with the fit itself)."""
    import vfmodel.pipeline.fit_job as fj
    import vfmodel.report.fit_figures as ff
    from vfmodel.core.atomic import atomic_path

    def stub(data: Any, model: Any, path: Path, *a: Any, **k: Any) -> None:
        with atomic_path(path) as tmp:
            tmp.write_bytes(b"\x89PNG stub")

    monkeypatch.setattr(fj, "run_fit", lambda *a, **k: fit_result)
    monkeypatch.setattr(ff, "plot_fit", stub)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_small_dataset(tmp_path_factory.mktemp("ds") / "ds", seed=4, n_samples=512)


# ---------------------------------------------------------------- bad output places
def _file(tmp: Path) -> Path:
    p = tmp / "afile"
    p.write_text("user data\n")
    return p


PLACES: dict[str, Any] = {
    "fit_out_below_file": lambda t, s: (["fit", str(s), "--out", str(_file(t) / "o")],
                                        "afile/o"),
    "fit_out_is_file": lambda t, s: (["fit", str(s), "--out", str(_file(t))], "afile"),
    "fit_out_deep_below_file": lambda t, s: (["fit", str(s), "--out",
                                              str(_file(t) / "a" / "b")], "afile/a/b"),
    "fit_out_proc": lambda t, s: (["fit", str(s), "--out", "/proc/vfmodel-out"],
                                  "/proc/vfmodel-out"),
    "fit_out_sys": lambda t, s: (["fit", str(s), "--out", "/sys/vfmodel-out"],
                                 "/sys/vfmodel-out"),
    "fit_spice_is_dir": lambda t, s: (["fit", str(s), "--out", str(t / "o"), "--spice",
                                       str(t / "d.cir")], "d.cir"),
    "fit_spice_below_file": lambda t, s: (["fit", str(s), "--out", str(t / "o"), "--spice",
                                           str(_file(t) / "m.cir")], "afile/m.cir"),
    "fit_spice_proc": lambda t, s: (["fit", str(s), "--out", str(t / "o"), "--spice",
                                     "/proc/vfmodel.cir"], "/proc/vfmodel.cir"),
    "convert_onto_dir": lambda t, s: (["convert", str(s), str(t / "d.csv")], "d.csv"),
    "convert_below_file": lambda t, s: (["convert", str(s), str(_file(t) / "x.csv")],
                                        "afile/x.csv"),
    "convert_proc": lambda t, s: (["convert", str(s), "/proc/vfmodel.s1p"],
                                  "/proc/vfmodel.s1p"),
    "convert_onto_input": lambda t, s: (["convert", str(s), str(s)], str(s)),
    "predict_out_below_file": lambda t, s: (["predict", str(t / "g.cir"), "--inverter",
                                             "v_dc=200", "--out", str(_file(t) / "o")],
                                            "afile/o"),
    "reproduce_out_below_file": lambda t, s: (["reproduce", str(t / "ds"), "--out",
                                               str(_file(t) / "o")], "afile/o"),
    "diagnose_out_below_file": lambda t, s: (["diagnose", str(t / "ds"), "--out",
                                              str(_file(t) / "o")], "afile/o"),
    "reproduce_out_is_file": lambda t, s: (["reproduce", str(t / "ds"), "--out",
                                            str(_file(t))], "afile"),
}


@pytest.mark.parametrize("case", sorted(PLACES))
def test_bad_output_place(case: str, tmp_path: Path, spectrum: Path, dataset: Path,
                          capsys: pytest.CaptureFixture[str],
                          monkeypatch: pytest.MonkeyPatch) -> None:
    import vfmodel.pipeline.diagnose as dg
    import vfmodel.pipeline.fit_job as fj
    import vfmodel.pipeline.reproduce as rp

    def never(*a: Any, **k: Any) -> Any:
        raise AssertionError("the output place must be checked before any computation")

    for mod, name in ((fj, "run_fit"), (rp, "reproduce"), (dg, "run_diagnose")):
        monkeypatch.setattr(mod, name, never)
    (tmp_path / "d.cir").mkdir()
    (tmp_path / "d.csv").mkdir()
    (tmp_path / "g.cir").write_text(GREYBOX_NETLIST)
    copy_tree(dataset, tmp_path / "ds")
    argv, name = PLACES[case](tmp_path, spectrum)
    before = snapshot(tmp_path)
    res = run_cli(capsys, argv)
    assert_refused(res, name, before, tmp_path)


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
@pytest.mark.parametrize("where", ["out", "parent", "spice"])
def test_read_only_places(where: str, tmp_path: Path, spectrum: Path,
                          capsys: pytest.CaptureFixture[str]) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    argv = ["fit", str(spectrum), "--out", str(ro if where == "out" else ro / "o")]
    if where == "spice":
        argv = ["fit", str(spectrum), "--out", str(tmp_path / "o"), "--spice",
                str(ro / "m.cir")]
    ro.chmod(0o555)
    try:
        before = snapshot(tmp_path)
        res = run_cli(capsys, argv)
        assert_refused(res, str(ro), before, tmp_path)
    finally:
        ro.chmod(0o755)


# ---------------------------------------------------------------- all together or nothing
def _fit_argv(spectrum: Path, out: Path, *extra: str) -> list[str]:
    return ["fit", str(spectrum), "--out", str(out), *extra]


def _earlier_run(out: Path) -> None:
    out.mkdir()
    (out / "model.json").write_text('{"earlier": true}\n')
    (out / "fit.png").write_bytes(b"\x89PNG earlier")
    (out / "notes.txt").write_text("the user's own file\n")


def test_second_fit_without_plot_removes_the_old_figure(
        tmp_path: Path, spectrum: Path, fake_fit: None,
        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "o"
    _earlier_run(out)
    res = run_cli(capsys, _fit_argv(spectrum, out, "--no-plot"))
    assert res.code == 0, res.err
    assert sorted(p.name for p in out.iterdir()) == [".vfmodel-outputs", "model.json",
                                                      "notes.txt", "report.html"]
    assert json.loads((out / "model.json").read_text())["kind"] == "Z"
    res = run_cli(capsys, _fit_argv(spectrum, out))
    assert res.code == 0, res.err
    assert (out / "fit.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / ".vfmodel-outputs").read_text().split() == ["fit.png", "model.json",
                                                              "report.html"]


FAILURES = {
    "plot_raises": ("vfmodel.report.fit_figures", "plot_fit", RuntimeError, 1),
    "plot_interrupted": ("vfmodel.report.fit_figures", "plot_fit", KeyboardInterrupt, 130),
    "spice_raises": ("vfmodel.circuit.synthesis", "model_to_spice", RuntimeError, 1),
    "spice_interrupted": ("vfmodel.circuit.synthesis", "model_to_spice", KeyboardInterrupt,
                          130),
    "json_raises": ("vfmodel.cli._common", "write_json", OSError, 1),
    "json_memory": ("vfmodel.cli._common", "write_json", MemoryError, 1),
    "fit_interrupted": ("vfmodel.pipeline.fit_job", "run_fit", KeyboardInterrupt, 130),
    "fit_raises": ("vfmodel.pipeline.fit_job", "run_fit", ValueError, 1),
}


@pytest.mark.parametrize("earlier", [False, True])
@pytest.mark.parametrize("case", sorted(FAILURES))
def test_failed_fit_leaves_nothing(case: str, earlier: bool, tmp_path: Path, spectrum: Path,
                                   fake_fit: None, capsys: pytest.CaptureFixture[str],
                                   monkeypatch: pytest.MonkeyPatch) -> None:
    import importlib

    module, name, exc, code = FAILURES[case]
    mod = importlib.import_module(module)
    real = getattr(mod, name)

    def failing(*a: Any, **k: Any) -> Any:
        if name != "run_fit":
            real(*a, **k)      # write the file, then fail
        raise exc("injected")

    monkeypatch.setattr(mod, name, failing)
    out = tmp_path / "o"
    if earlier:
        _earlier_run(out)
    before = snapshot(tmp_path)
    res = run_cli(capsys, _fit_argv(spectrum, out, "--spice", str(tmp_path / "m.cir")))
    assert_refused(res, "", before, tmp_path, code=code, one_line=False)
    assert ("interrupted" in res.err) == (code == 130)


class _FakeReproduce:
    def __init__(self, netlists: dict[str, str]) -> None:
        self.results = {"impedance": {}, "bearing": {}, "baseline_bvr": {},
                        "nan_value": float("nan")}
        self.netlists = netlists


@pytest.mark.parametrize("fail", ["none", "run_interrupted", "figures_raise",
                                  "figures_interrupted", "html_raises"])
def test_reproduce_outputs_swap_in_together(fail: str, tmp_path: Path, dataset: Path,
                                            capsys: pytest.CaptureFixture[str],
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    import vfmodel.pipeline.reproduce as rp
    import vfmodel.report.html as html
    import vfmodel.report.reproduce_figures as figs

    ds = copy_tree(dataset, tmp_path / "ds")
    out = tmp_path / "o"
    out.mkdir()
    for name in ("results.json", "report.html", "network_0rpm.cir", "fig19_impedance_cm.png",
                 "poles.png"):
        (out / name).write_text(f"earlier {name}\n")
    (out / "notes.txt").write_text("mine\n")

    def run(*a: Any, **k: Any) -> Any:
        if fail == "run_interrupted":
            raise KeyboardInterrupt
        return _FakeReproduce({"network_100rpm.cir": "* new\n.end\n"})

    def write_figures(res: Any, out_dir: Path) -> list[str]:
        (out_dir / "fig23_lubricant.png").write_bytes(b"\x89PNG new")
        if fail.startswith("figures"):
            raise KeyboardInterrupt if fail.endswith("interrupted") else RuntimeError("x")
        return ["fig23_lubricant.png"]

    def write_html(path: Path, results: Any, figures: Any) -> None:
        if fail == "html_raises":
            raise OSError(28, "No space left on device")
        path.write_text("<html>new</html>")

    monkeypatch.setattr(rp, "reproduce", run)
    monkeypatch.setattr(figs, "write_figures", write_figures)
    monkeypatch.setattr(html, "write_reproduce_html", write_html)
    before = snapshot(tmp_path)
    res = run_cli(capsys, ["reproduce", str(ds), "--out", str(out)])
    assert "Traceback" not in res.err
    if fail == "none":
        assert res.code == 0, res.err
        assert sorted(p.name for p in out.iterdir()) == [
            ".vfmodel-outputs", "fig23_lubricant.png", "network_100rpm.cir", "notes.txt",
            "report.html", "results.json"]
        doc = json.loads((out / "results.json").read_text(), parse_constant=_no_constant)
        assert doc["nan_value"] is None
    else:
        assert res.code == (130 if "interrupted" in fail else 1), res.err
        assert snapshot(tmp_path) == before


def _no_constant(token: str) -> Any:
    raise AssertionError(f"non-standard JSON token {token}")


@pytest.mark.parametrize("fail", ["none", "crash_at_end", "interrupted"])
def test_diagnose_infinite_significance_and_crash(fail: str, tmp_path: Path, dataset: Path,
                                                  capsys: pytest.CaptureFixture[str],
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """A mismatch far beyond the noise has an infinite significance: written as null
    (strict JSON); a crash at the very end leaves neither report nor figures."""
    import vfmodel.pipeline.diagnose as dg
    import vfmodel.report.diagnose_figures as df

    doc = {"mismatch_found": True, "sentence": "far from the data",
           "mismatches": [{"where": "impedance:U-Frame", "band_hz": [1e3, float("inf")],
                           "significance": float("inf")}],
           "findings": [], "rejected": []}
    monkeypatch.setattr(dg, "run_diagnose",
                        lambda *a, **k: SimpleNamespace(family=None, diagnosis=None,
                                                        document=doc))

    def figures(family: Any, d: Any, out: Path) -> list[str]:
        (out / "residual_impedance_U-Frame.png").write_bytes(b"\x89PNG")
        if fail == "interrupted":
            raise KeyboardInterrupt
        return ["residual_impedance_U-Frame.png"]

    def html(path: Path, document: Any, figs: Any) -> None:
        path.write_text("<html></html>")
        if fail == "crash_at_end":
            raise RuntimeError("crash")

    monkeypatch.setattr(df, "write_diagnose_figures", figures)
    monkeypatch.setattr(df, "write_diagnose_html", html)
    ds = copy_tree(dataset, tmp_path / "ds")
    out = tmp_path / "o"
    before = snapshot(tmp_path)
    res = run_cli(capsys, ["diagnose", str(ds), "--out", str(out)])
    assert "Traceback" not in res.err
    if fail == "none":
        assert res.code == 0, res.err
        d = json.loads((out / "diagnosis.json").read_text(), parse_constant=_no_constant)
        assert d["mismatches"][0]["significance"] is None
        assert d["mismatches"][0]["band_hz"] == [1e3, None]
    else:
        assert res.code == (130 if fail == "interrupted" else 1)
        assert snapshot(tmp_path) == before


@pytest.mark.parametrize("mask", [0o022, 0o077, 0o002])
def test_outputs_respect_the_umask(mask: int, tmp_path: Path, spectrum: Path,
                                   fake_fit: None, capsys: pytest.CaptureFixture[str]) -> None:
    old = os.umask(mask)
    try:
        res = run_cli(capsys, _fit_argv(spectrum, tmp_path / "o", "--spice",
                                        str(tmp_path / "m.cir")))
        res2 = run_cli(capsys, ["convert", str(spectrum), str(tmp_path / "c.s1p")])
    finally:
        os.umask(old)
    assert res.code == 0 and res2.code == 0, res.err + res2.err
    assert (tmp_path / "o").stat().st_mode & 0o777 == 0o777 & ~mask
    for p in (tmp_path / "o" / "model.json", tmp_path / "o" / "fit.png",
              tmp_path / "m.cir", tmp_path / "c.s1p"):
        assert p.stat().st_mode & 0o777 == 0o666 & ~mask, p


def test_strict_json_everywhere(tmp_path: Path, spectrum: Path, fake_fit: None,
                                capsys: pytest.CaptureFixture[str]) -> None:
    from vfmodel.core.atomic import finite_json

    assert finite_json({"a": [1.0, float("inf"), np.float64("nan")], "b": (np.inf,)}) == {
        "a": [1.0, None, None], "b": [None]}
    res = run_cli(capsys, _fit_argv(spectrum, tmp_path / "o"))
    assert res.code == 0, res.err
    json.loads((tmp_path / "o" / "model.json").read_text(), parse_constant=_no_constant)


# ---------------------------------------------------------------- Ctrl-C, start-up
_SLOW_FIT = """
import sys, time
import vfmodel.pipeline.fit_job as fj
def slow(*a, **k):
    print("computing", flush=True)
    time.sleep(60)
fj.run_fit = slow
sys.argv = ["vfmodel", "fit", sys.argv[1], "--out", sys.argv[2]]
from vfmodel.cli._entry import entry
entry()
"""

_SLOW_IMPORT = """
import sys, time, types
class Slow(types.ModuleType):
    def __getattr__(self, name):
        print("importing", flush=True)
        time.sleep(60)
sys.modules["vfmodel.cli.main"] = Slow("vfmodel.cli.main")
sys.argv = ["vfmodel", "--help"]
from vfmodel.cli._entry import entry
entry()
"""


def _interrupt(code: str, args: list[str], marker: str) -> tuple[int, str]:
    proc = subprocess.Popen([PYTHON, "-c", code, *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    line = proc.stdout.readline()
    assert marker in line, line
    time.sleep(0.1)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    return proc.returncode, err


def test_ctrl_c_during_a_command(tmp_path: Path, spectrum: Path) -> None:
    code, err = _interrupt(_SLOW_FIT, [str(spectrum), str(tmp_path / "o")], "computing")
    assert code == 130, err
    assert "Traceback" not in err and "interrupted" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["z.csv"]   # no output, no stage


def test_ctrl_c_during_start_up() -> None:
    code, err = _interrupt(_SLOW_IMPORT, [], "importing")
    assert code == 130, err
    assert "Traceback" not in err and "interrupted" in err


def test_cli_import_is_light() -> None:
    """``vfmodel --help`` and ``info`` start without the heavy libraries (issue 18)."""
    probe = ("import sys, vfmodel.cli.main as m; m.cli.list_commands(None); "
             "[m.cli.get_command(None, c) for c in m.cli.list_commands(None)]; "
             "print(' '.join(x for x in ('scipy.signal', 'matplotlib', 'cvxpy', 'skrf') "
             "if x in sys.modules))")
    out = subprocess.run([PYTHON, "-c", probe], capture_output=True, text=True, timeout=60,
                         check=True).stdout
    assert out.strip() == "", out


def test_blas_threads_capped() -> None:
    probe = ("import os; os.environ['OPENBLAS_NUM_THREADS'] = '8'; import numpy; "
             "from vfmodel.cli import main as m; import threadpoolctl; "
             "seen = []; m._main = lambda argv: seen.append(max(i['num_threads'] for i in "
             "threadpoolctl.threadpool_info() if i['user_api'] == 'blas')) or 0; "
             "m.main([]); print(seen[0], os.environ['OPENBLAS_NUM_THREADS'])")
    out = subprocess.run([PYTHON, "-c", probe], capture_output=True, text=True, timeout=60,
                         check=True).stdout.split()
    assert out == ["1", "8"], out
