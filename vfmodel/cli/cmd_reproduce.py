"""``vfmodel reproduce DATASET --out DIR``: the reference paper's pipeline (CONTRACT 3, 6)."""

from __future__ import annotations

from pathlib import Path
from typing import get_args

import click

from vfmodel._choices import SectionsBy
from vfmodel.cli._common import out_option, progress_bar, quiet_option, write_json
from vfmodel.greybox.effects import (
    JOINT_REFIT,
    LUBRICANT_MAX_NFEV,
    LUBRICANT_RANDOM_STARTS,
    SECTIONS,
)

REPRODUCE_OUTPUTS = ("results.json", "report.html", "network_*rpm.cir", "fig*.png",
                     "blackbox_errors.png", "poles.png")
"""Outputs of ``reproduce`` in DIR (an earlier run's are replaced, never mixed)."""


def _sections(value: str) -> tuple[int, ...]:
    try:
        out = tuple(int(v) for v in value.split(",") if v.strip())
    except ValueError:
        raise click.BadParameter(f"{value!r}: expected integers >= 2, e.g. '2,3,4'") from None
    if not out or min(out) < 2:
        raise click.BadParameter(f"{value!r}: expected integers >= 2, e.g. '2,3,4'")
    return out


@click.command()
@click.argument("dataset", type=click.Path(path_type=Path))
@click.option("--sections", default=",".join(map(str, SECTIONS)), show_default=True,
              help="Candidate winding sections per phase (2 = the paper's model); the "
                   "identification keeps the best the spectra support.")
@click.option("--sections-by", type=click.Choice(get_args(SectionsBy)), default="spectra",
              show_default=True,
              help="Choose the winding-section count by the impedance spectra alone, or "
                   "among the spectra's choice and its neighbours by the fit of the "
                   "rotating records (an identification per count tried).")
@click.option("--no-blackbox", is_flag=True, help="Skip the black-box comparison.")
@click.option("--max-nfev", default=40, show_default=True, type=click.IntRange(5, 1000),
              help="Function evaluations per identification stage.")
@click.option("--max-nfev-lubricant", default=LUBRICANT_MAX_NFEV, show_default=True,
              type=click.IntRange(5, 1000),
              help="Function evaluations per start of each lubricant (per-speed) stage.")
@click.option("--lubricant-random-starts", default=LUBRICANT_RANDOM_STARTS,
              show_default=True, type=click.IntRange(0, 50),
              help="Random starts added to the three physical starts of each lubricant "
                   "stage.")
@click.option("--joint/--no-joint", default=JOINT_REFIT, show_default=True,
              help="Refit the rotor-side capacitances and the rotor-current path with "
                   "every rotating record (kept only where the impedance spectra stay "
                   "within 1.1x their misfit; its intervals widened by the shift from the "
                   "stage-wise fit).")
@click.option("--priors", is_flag=True, help="Maximum a posteriori identification with "
              "the physical priors of the grey-box parameters (dataset.toml [machine], "
              "[bearing], [priors]); model.rel_std in results.json is then posterior.")
@click.option("--add-effect", "add_effects", multiple=True, metavar="EFFECT",
              help="Add an effect to the paper's network (repeatable), e.g. one that "
                   "`vfmodel diagnose` found: endwinding_capacitance, fixture_inductance.")
@out_option
@quiet_option
def reproduce(dataset: Path, sections: str, sections_by: str, no_blackbox: bool,
              max_nfev: int,
              max_nfev_lubricant: int, lubricant_random_starts: int, joint: bool,
              priors: bool,
              add_effects: tuple[str, ...], out_dir: Path, quiet: bool) -> None:
    """Identify the grey-box model of DATASET (impedance spectra, then the H1 transfer of the
    recordings, lubricant per speed), validate it, compare it with the classical BVR model
    and a black-box fit. Writes DIR/results.json, figures (PNG), DIR/report.html and
    DIR/network_<rpm>rpm.cir for every recorded speed."""
    from vfmodel.core.atomic import atomic_write_text, staged_output
    from vfmodel.core.io_dataset import read_dataset
    from vfmodel.greybox.effects import PAPER_EFFECTS, check_effects
    from vfmodel.pipeline.reproduce import reproduce as run
    from vfmodel.report.html import write_reproduce_html
    from vfmodel.report.reproduce_figures import write_figures

    secs = _sections(sections)
    effects = PAPER_EFFECTS | check_effects(add_effects, "--add-effect")
    with staged_output(out_dir, owned=REPRODUCE_OUTPUTS) as stage:
        ds = read_dataset(dataset)
        prog = progress_bar(quiet)
        res = run(ds, effects=sorted(effects), sections=secs, blackbox=not no_blackbox,
                  max_nfev=max_nfev, progress=prog, priors=priors,
                  max_nfev_lubricant=max_nfev_lubricant,
                  lubricant_random_starts=lubricant_random_starts, joint=joint,
                  sections_by=sections_by)  # type: ignore[arg-type]
        for name, text in res.netlists.items():
            atomic_write_text(stage.path(name), text)
        prog("figures", 0, 1)
        figs = write_figures(res, stage.dir)
        prog("figures", 1, 1)
        write_reproduce_html(stage.path("report.html"), res.results, figs)
        write_json(stage.path("results.json"), res.results)
    r = res.results
    imp = r.get("impedance", {})
    bea = r.get("bearing", {})
    if imp:
        click.echo(f"impedance: mean MAPE {imp['mean_mape_pct']:.2f} %, mean coherence "
                   f"{imp['mean_coherence']:.5f}")
    if "mean_rel_err_pct_rotating" in bea:
        click.echo(f"bearing voltage: mean rel. peak error (rotating) "
                   f"{bea['mean_rel_err_pct_rotating']:.2f} %, mean spectral corr. "
                   f"{bea['mean_spectral_corr']:.4f}")
    click.echo(f"wrote {out_dir / 'results.json'}, report.html, {len(figs)} figures, "
               f"{len(res.netlists)} netlists")
