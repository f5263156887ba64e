"""``vfmodel fit SPECTRUM... --out DIR``: vector fit to a rational model (CONTRACT 3, 4)."""

from __future__ import annotations

from pathlib import Path

import click

from vfmodel.cli._common import out_option, progress_bar, quiet_option
from vfmodel.core.atomic import staged_output
from vfmodel.core.io_spectrum import read_spectrum, spectrum_format
from vfmodel.errors import InputError

FIT_OUTPUTS = ("model.json", "fit.png")
"""Outputs of ``fit`` in DIR (an earlier run's are replaced, never mixed with a new one)."""


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
@click.option("--weighting", type=click.Choice(["uniform", "inv_abs", "inv_sqrt_abs"]),
              default="uniform", show_default=True, help="Least-squares weights.")
@click.option("--passive", is_flag=True, help="Enforce passivity (certified by the "
              "Hamiltonian test) with a convex program.")
@click.option("--spice", "spice", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="Also write a SPICE subcircuit '.subckt vfmodel p1..pN ref'.")
@click.option("--no-plot", is_flag=True, help="Do not write fit.png.")
@out_option
@quiet_option
def fit(spectra: tuple[Path, ...], order: str, kind: str | None, weighting: str,
        passive: bool, spice: Path | None, no_plot: bool, out_dir: Path, quiet: bool) -> None:
    """Vector-fit one or more spectra (Touchstone of any port count, or CSV) to a rational
    model with common poles; several files make a block-diagonal model. Writes
    DIR/model.json (CONTRACT section 4) and DIR/fit.png."""
    n_order = _order(order)
    if spice is not None and spice.suffix.lower() not in (".cir", ".sp", ".spice", ".lib",
                                                          ".sub", ".subckt", ".net"):
        raise InputError("unknown SPICE file suffix", source=str(spice),
                         expected=".cir, .sp, .spice, .lib, .sub or .net")
    for p in spectra:
        spectrum_format(p)
    with staged_output(out_dir, owned=FIT_OUTPUTS) as stage:
        spice_tmp = None if spice is None else stage.extra(spice, "--spice")
        _fit(spectra, n_order, kind, weighting, passive, spice, spice_tmp, no_plot, out_dir,
             stage.dir, quiet)


def _fit(spectra: tuple[Path, ...], n_order: int | str, kind: str | None, weighting: str,
         passive: bool, spice: Path | None, spice_tmp: Path | None, no_plot: bool,
         out_dir: Path, stage: Path, quiet: bool) -> None:
    """Fit and write every output into the staging folder ``stage``."""
    from vfmodel.fitting.model_json import model_to_json
    from vfmodel.pipeline.fit_job import run_fit

    data = [read_spectrum(p) for p in spectra]
    res = run_fit(data, order=n_order, kind=kind, weighting=weighting,  # type: ignore[arg-type]
                  passive=passive, progress=progress_bar(quiet))
    f = res.data.freq_hz
    obj = model_to_json(res.model, res.fit, (float(f[0]), float(f[-1])),
                        None if res.passivity is None else res.passivity.passive)
    if res.passivity is not None:
        obj["passivity"] = {
            "method": res.passivity.method,
            "bands_hz": [list(b) for b in res.passivity.bands_hz],
            "worst_violation": res.passivity.worst_violation,
            "enforcement_iterations": res.passivity.iterations,
            "unconstrained_rel_rms_error": res.unconstrained_rel_rms_error,
        }
    obj["order_reason"] = res.fit.order_reason
    obj["sources"] = [str(p) for p in spectra]
    from vfmodel.cli._common import write_json

    if spice_tmp is not None:
        from vfmodel.circuit.synthesis import model_to_spice

        spice_tmp.write_text(model_to_spice(res.model, name="vfmodel"), encoding="utf-8")
    write_json(stage / "model.json", obj)
    if not no_plot:
        from vfmodel.report.fit_figures import plot_fit

        plot_fit(res.data, res.model, stage / "fit.png")
    status = "not checked" if res.passivity is None else (
        "passive (certified)" if res.passivity.passive else
        f"NOT passive ({len(res.passivity.bands_hz)} violation bands)")
    click.echo(f"fitted {res.data.n_out}x{res.data.n_in} {res.data.kind}, "
               f"{res.model.n_poles} poles ({res.fit.order_reason})")
    click.echo(f"rel RMS error {res.rel_rms_error:.3e} (unconstrained "
               f"{res.unconstrained_rel_rms_error:.3e}); {status}")
    click.echo(f"wrote {out_dir / 'model.json'}" + (f", {spice}" if spice else ""))
