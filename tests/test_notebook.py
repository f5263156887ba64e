"""Notebook use: ``_repr_html_`` and ``.plot()`` of the result types; matplotlib is not
imported by ``import vfmodel`` nor by a fit, only by ``.plot()``."""

from __future__ import annotations

import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest

import vfmodel
from vfmodel.report.units import si


def test_import_does_not_load_matplotlib() -> None:
    code = ("import sys, numpy as np, vfmodel\n"
            "f = np.logspace(3, 7, 41); s = 2j * np.pi * f\n"
            "d = vfmodel.FrequencyData(f, (5 + 1 / (s * 1e-9) + s * 1e-6)[:, None, None],"
            " kind='Z')\n"
            "m, r = vfmodel.vector_fit(d, order=2)\n"
            "c = vfmodel.check_passivity(m)\n"
            "html = m._repr_html_() + r._repr_html_() + c._repr_html_()\n"
            "assert 'RationalModel' in html\n"
            "print('matplotlib' in sys.modules)\n"
            "m.plot(); print('matplotlib' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env={"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin",
                                          "OPENBLAS_NUM_THREADS": "1"})
    assert out.stdout.split() == ["False", "True"]


@pytest.fixture(scope="module")
def fitted() -> tuple[object, object, object]:
    f = np.logspace(3, 7, 41)
    s = 2j * np.pi * f
    data = vfmodel.FrequencyData(f, (5 + 1 / (s * 1e-9) + s * 1e-6)[:, None, None], kind="Z")
    model, report = vfmodel.vector_fit(data, order=2)
    return model, report, vfmodel.check_passivity(model)


def test_html_summaries_use_engineering_units(fitted: tuple[object, ...]) -> None:
    model, report, check = fitted
    h = model._repr_html_()  # type: ignore[attr-defined]
    assert "RationalModel" in h and "Z" in h and "Hz" in h and "<table" in h
    assert "FitReport" in report._repr_html_()  # type: ignore[attr-defined]
    p = check._repr_html_()  # type: ignore[attr-defined]
    assert "PassivityReport" in p and "certified" in p


def test_plots_return_axes(fitted: tuple[object, ...]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.axes import Axes

    model = fitted[0]
    for obj in fitted:
        ax = obj.plot()  # type: ignore[attr-defined]
        assert isinstance(ax, Axes)
    ax = model.plot(np.logspace(3, 7, 50))  # type: ignore[attr-defined]
    assert len(ax.lines) == 1
    np.testing.assert_allclose(ax.lines[0].get_ydata(),
                               np.abs(model(np.logspace(3, 7, 50))[:, 0, 0]),  # type: ignore[operator]
                               rtol=1e-12)
    plt.close("all")


def test_reproduce_and_diagnose_views() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tests._report_data import diagnose_document, reproduce_results
    from vfmodel.pipeline.diagnose import DiagnoseResult
    from vfmodel.pipeline.reproduce import ReproduceResult

    u = np.sin(np.linspace(0, 20, 500))
    sp = SimpleNamespace(speed_rpm=100.0, fs=1e8, u_meas=u, u_model=0.9 * u, u_bvr=0.5 * u)
    res = ReproduceResult(reproduce_results(), None, (sp,), None, None, {})  # type: ignore[arg-type]
    h = res._repr_html_()
    r = res.results
    assert si(r["impedance"]["mean_mape_pct"], "%") in h
    assert "300" in h                                         # the flagged speed named
    ax = res.plot()
    assert len(ax.lines) == 3
    np.testing.assert_allclose(ax.lines[1].get_ydata(), 0.9 * u)
    doc = diagnose_document()
    f = np.logspace(3, 6, 20)
    ch = SimpleNamespace(where="impedance:Zin", freq_hz=f, measured=1 / f)
    fam = SimpleNamespace(channels=[ch], predict=lambda applied, params: [2 / f])
    fit = SimpleNamespace(applied=(), params=None)
    dg = SimpleNamespace(mismatches=[SimpleNamespace(where="impedance:Zin")], start=fit,
                         final=fit)
    d = DiagnoseResult(fam, dg, doc)  # type: ignore[arg-type]
    assert "2.155 → 0.9804" in d._repr_html_()
    ax = d.plot()
    assert ax.get_title() == "impedance:Zin" and len(ax.lines) == 3
    plt.close("all")
