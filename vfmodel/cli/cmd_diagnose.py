"""``vfmodel diagnose DATASET [--without E1,...] [--model FILE] --out DIR`` (CONTRACT 3, 7)."""

from __future__ import annotations

from pathlib import Path

import click

from vfmodel.cli._common import out_option, progress_bar, quiet_option, write_json

DIAGNOSE_OUTPUTS = ("diagnosis.json", "report.html", "residual_*.png", "overlay_*.png",
                    "waveform_bearing_*rpm.png", "poles.png")
"""Outputs of ``diagnose`` in DIR (an earlier run's are replaced, never mixed)."""


def _effects(value: str) -> tuple[str, ...]:
    from vfmodel._choices import EFFECTS

    out = tuple(v.strip() for v in value.split(",") if v.strip())
    bad = [v for v in out if v not in EFFECTS]
    if bad:
        raise click.BadParameter(f"{bad[0]!r} is not an effect; expected a comma-separated "
                                 f"list of: {', '.join(EFFECTS)}")
    return out


@click.command()
@click.argument("dataset", type=click.Path(path_type=Path))
@click.option("--without", default="", help="Comma-separated effects removed from the "
              "paper's full model to form the starting network (PMSM model).")
@click.option("--model", "model", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="A user network (netlist with parameter bounds and .effect "
              "candidates; see vfmodel.detective.user_model) instead of the PMSM model.")
@click.option("--max-nfev", default=None, type=click.IntRange(5, 1000),
              help="Function evaluations per refit (default: 60 for --model, 30 for the "
              "PMSM model).")
@click.option("--priors", is_flag=True, help="Maximum a posteriori refits with the "
              "physical priors of the grey-box parameters (dataset.toml [machine], "
              "[bearing], [priors]; PMSM model).")
@click.option("--film-law", "film_law", is_flag=True, default=False,
              help="The lubricant film follows a power law in speed instead of free values "
              "per speed (PMSM model; needs >= 2 rotating speeds); diagnosis.json says "
              "whether the data support the law or free values (BIC).")
@out_option
@quiet_option
def diagnose(dataset: Path, without: str, model: Path | None, max_nfev: int | None,
             priors: bool, film_law: bool, out_dir: Path, quiet: bool) -> None:
    """Fit the starting network to DATASET, locate where it disagrees with the data beyond
    the noise, try every effect it lacks, keep what the data support. Writes
    DIR/diagnosis.json, figures (PNG) and DIR/report.html."""
    from vfmodel.core.atomic import staged_output
    from vfmodel.errors import InputError
    from vfmodel.pipeline.diagnose import run_diagnose
    from vfmodel.report.diagnose_figures import write_diagnose_figures, write_diagnose_html

    if not dataset.exists():
        raise InputError("dataset directory not found", source=str(dataset))
    eff = _effects(without)
    with staged_output(out_dir, owned=DIAGNOSE_OUTPUTS) as stage:
        prog = progress_bar(quiet)
        opts = {} if max_nfev is None else {"max_nfev": max_nfev}
        res = run_diagnose(dataset, without=eff, model=model, priors=priors,
                           film_law=film_law, progress=prog, **opts)
        prog("figures", 0, 1)
        figs = write_diagnose_figures(res.family, res.diagnosis, stage.dir)
        prog("figures", 1, 1)
        write_diagnose_html(stage.path("report.html"), res.document, figs)
        write_json(stage.path("diagnosis.json"), res.document)
    click.echo(res.document["sentence"])
    if "film_law" in res.document:
        click.echo(res.document["film_law"]["sentence"])
    click.echo(f"wrote {out_dir / 'diagnosis.json'}, report.html, {len(figs)} figures")
