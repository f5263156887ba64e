"""``vfmodel fit SPECTRUM... --out DIR``: vector fit to a rational model (CONTRACT 3, 4)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from vfmodel.cli._common import finite_json, out_option, progress_bar, quiet_option
from vfmodel.core.atomic import staged_output
from vfmodel.core.io_spectrum import read_spectrum, spectrum_format
from vfmodel.errors import InputError
from vfmodel.fitting.defaults import ENFORCE_ITERATIONS, ENFORCE_TIME_LIMIT

FIT_OUTPUTS = ("model.json", "fit.png", "report.html")
"""Outputs of ``fit`` in DIR (an earlier run's are replaced, never mixed with a new one)."""


def _delay(value: str) -> float | str:
    if value in ("auto", "none"):
        return value
    try:
        tau = float(value)
    except ValueError:
        tau = -1.0
    if not (tau >= 0 and tau < float("inf")):
        raise click.BadParameter(f"{value!r}: expected auto, none or a delay in seconds",
                                 param_hint="--delay")
    return tau


def _order(value: str) -> int | str:
    if value == "auto":
        return "auto"
    try:
        n = int(value)
    except ValueError:
        raise click.BadParameter(f"{value!r}: expected a positive integer or 'auto'") from None
    if n < 1:
        raise click.BadParameter(f"{value!r}: expected a positive integer or 'auto'")
    return n


@click.command()
@click.argument("spectra", metavar="SPECTRUM...", nargs=-1, required=True,
                type=click.Path(path_type=Path))
@click.option("--order", default="auto", show_default=True,
              help="Number of poles (conjugate poles counted separately) or 'auto'.")
@click.option("--kind", type=click.Choice(["Z", "Y", "S", "H"]), default=None,
              help="Representation to fit (default: the data's).")
@click.option("--weight", "--weighting", "weighting",
              type=click.Choice(["auto", "relative", "uniform", "inverse", "inverse-sqrt",
                                 "inv_abs", "inv_sqrt_abs"]),
              default="auto", show_default=True,
              help="Least-squares weights: relative = 1/||H(f)|| per frequency (per-point "
              "relative accuracy), uniform, inverse = 1/|H_ij|, inverse-sqrt = "
              "1/sqrt|H_ij|; auto = relative for Z/Y/H data spanning decades, else uniform.")
@click.option("--max-order", type=click.IntRange(min=1), default=None,
              help="Upper limit of the automatic order.")
@click.option("--target-error", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Automatic order: stop at this weighted relative RMS error instead of "
              "the estimated noise floor.")
@click.option("--delay", default="auto", show_default=True,
              help="Common delay taken out before the fit and kept in the model (S and "
              "H data): 'auto' (when the phase turns more than 5 times over the band), "
              "'none' or seconds. Exported to SPICE as matched lossless lines (T).")
@click.option("--dc", type=click.Choice(["enforce", "fit"]), default="enforce",
              show_default=True, help="A 0 Hz sample: matched exactly or fitted like "
              "the others.")
@click.option("--passive", is_flag=True, help="Enforce passivity (certified by the "
              "Hamiltonian test and a sampling cross-check) with a convex program.")
@click.option("--enforce-iterations", type=click.IntRange(min=1),
              default=ENFORCE_ITERATIONS,
              show_default=True, help="Convex programs of the passivity enforcement.")
@click.option("--enforce-margin", type=click.FloatRange(min=0, max=0.1, min_open=True,
                                                        max_open=True),
              default=None,
              help="Relative passivity margin required at the cut frequencies, kept in "
              "the final model [default: 1e-6, or a tenth of max(fit error, data floor) when "
              "smaller, at least 1e-10; the default margin only helps the convex programs and "
              "the final model may give it back].")
@click.option("--enforce-time-limit", type=click.FloatRange(min=0), default=ENFORCE_TIME_LIMIT,
              show_default=True, help="Seconds from the start of passivity enforcement "
              "after which the running convex program stops and no further one starts (the "
              "first enforcement and, for S data of at most 4 ports, its retries for an "
              "enforced error within 1.2x of max(fit error, data floor)); no certified "
              "model by then exits 2; 0: no limit.")
@click.option("--spice", "spice", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="Also write a SPICE subcircuit '.subckt NAME p1..pN ref'.")
@click.option("--subckt-name", default="vfmodel", show_default=True,
              help="Name of the SPICE subcircuit.")
@click.option("--no-plot", is_flag=True, help="Do not write fit.png.")
@out_option
@quiet_option
def fit(spectra: tuple[Path, ...], order: str, kind: str | None, weighting: str,
        max_order: int | None, target_error: float | None, delay: str, dc: str,
        passive: bool,
        enforce_iterations: int, enforce_margin: float | None, enforce_time_limit: float,
        spice: Path | None,
        subckt_name: str, no_plot: bool, out_dir: Path, quiet: bool) -> None:
    """Vector-fit one or more spectra (Touchstone of any port count, or CSV) to a rational
    model with common poles; several files make a block-diagonal model. Writes
    DIR/model.json (CONTRACT section 4), DIR/fit.png and DIR/report.html.

    Also reported: the per-point relative error (RMS and max over frequency of
    ||H_model - H|| / ||H||) and, for square Z/Y/S data, the data's own passivity
    violation floor (relative distance of the samples to the nearest passive ones);
    active data are refused by --passive."""
    import re

    n_order = _order(order)
    if not enforce_time_limit >= 0:  # click's FloatRange lets NaN through
        raise click.BadParameter(f"{enforce_time_limit!r}: expected seconds >= 0 "
                                 "(0: no limit)", param_hint="--enforce-time-limit")
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_.\-]*", subckt_name):
        raise click.BadParameter(f"{subckt_name!r}: expected a SPICE name (letters, digits, "
                                 "_ . -, starting with a letter or _)",
                                 param_hint="--subckt-name")
    opts = {"delay": _delay(delay), "max_order": max_order, "target_error": target_error, "dc": dc,
            "enforce_iterations": enforce_iterations, "enforce_margin": enforce_margin,
            "enforce_time_limit": enforce_time_limit}
    if spice is not None and spice.suffix.lower() not in (".cir", ".sp", ".spice", ".lib",
                                                          ".sub", ".subckt", ".net"):
        raise InputError("unknown SPICE file suffix", source=str(spice),
                         expected=".cir, .sp, .spice, .lib, .sub or .net")
    for p in spectra:
        spectrum_format(p)
    with staged_output(out_dir, owned=FIT_OUTPUTS) as stage:
        spice_tmp = None if spice is None else stage.extra(spice, "--spice")
        _fit(spectra, n_order, kind, weighting, passive, spice, spice_tmp, no_plot, out_dir,
             stage.dir, quiet, subckt_name, opts)


def _fit(spectra: tuple[Path, ...], n_order: int | str, kind: str | None, weighting: str,
         passive: bool, spice: Path | None, spice_tmp: Path | None, no_plot: bool,
         out_dir: Path, stage: Path, quiet: bool, subckt_name: str,
         opts: dict[str, Any]) -> None:
    """Fit and write every output into the staging folder ``stage``."""
    from vfmodel.pipeline.fit_job import fit_model_json, fit_spice_text, run_fit

    data = [read_spectrum(p) for p in spectra]
    res = run_fit(data, order=n_order, kind=kind, weighting=weighting,  # type: ignore[arg-type]
                  passive=passive, progress=progress_bar(quiet), **opts)
    obj = fit_model_json(res, [str(p) for p in spectra])
    if spice_tmp is not None:
        spice_tmp.write_text(fit_spice_text(res, subckt_name), encoding="utf-8")
    from vfmodel.cli._common import write_json  # looked up at call time (tests inject)

    write_json(stage / "model.json", obj)
    if not no_plot:
        from vfmodel.report.fit_figures import plot_fit

        plot_fit(res.data, res.model, stage / "fit.png")
    from vfmodel.report.fit_html import write_fit_html

    write_fit_html(stage / "report.html", finite_json(obj), [] if no_plot else ["fit.png"])
    status = "not checked" if res.passivity is None else res.passivity.describe()
    click.echo(f"fitted {res.data.n_out}x{res.data.n_in} {res.data.kind}, "
               f"{res.model.n_poles} poles ({res.fit.order_reason})")
    click.echo(f"rel RMS error {res.rel_rms_error:.3e} (unconstrained "
               f"{res.unconstrained_rel_rms_error:.3e}); per point: RMS "
               f"{res.fit.point_rel_rms_error:.3e}, max {res.fit.point_rel_max_error:.3e} "
               f"(weighting {res.fit.weighting}); {status}")
    dp = res.data_passivity
    if dp is not None:
        click.echo(f"data passivity floor {dp.floor:.3e} (largest violation of the data "
                   f"{dp.worst_violation:.3g}" + (", ACTIVE data" if dp.active else "") + ")")
    click.echo(f"wrote {out_dir / 'model.json'}" + (f", {spice}" if spice else ""))
