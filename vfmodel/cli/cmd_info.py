"""``vfmodel info DATASET``: what a dataset holds."""

from __future__ import annotations

import json
from pathlib import Path

import click

from vfmodel.cli._common import finite_json


@click.command()
@click.argument("dataset", type=click.Path(path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def info(dataset: Path, as_json: bool) -> None:
    """Topologies, frequency ranges, recordings, sample rates, durations and SNR estimates."""
    from vfmodel.core.io_dataset import read_dataset
    from vfmodel.pipeline.summary import dataset_summary

    summary = dataset_summary(read_dataset(dataset))
    if as_json:
        click.echo(json.dumps(finite_json(summary), indent=2, allow_nan=False))
        return
    click.echo(f"dataset {summary['name']}  ({summary['root']})")
    if summary["description"]:
        click.echo(f"  {summary['description']}")
    if summary["temperature_c"] is not None:
        click.echo(f"  temperature {summary['temperature_c']:g} degC")
    click.echo(f"impedance spectra: {len(summary['impedance'])}")
    for topo, s in summary["impedance"].items():
        click.echo(
            f"  {topo:8s} {s['n_points']:5d} points  {s['f_min_hz']:10.4g} - "
            f"{s['f_max_hz']:10.4g} Hz   |Z| {s['z_min_ohm']:.4g} - {s['z_max_ohm']:.4g} ohm"
            f"   noise ~{s['noise_pct']:.2g} %"
        )
    click.echo(f"recordings: {len(summary['recordings'])}")
    for r in summary["recordings"]:
        click.echo(
            f"  {r['speed_rpm']:6g} rpm  fs {r['fs_hz'] / 1e6:g} MS/s  {r['n_samples']} samples"
            f"  {r['duration_s'] * 1e3:.4g} ms  raw peak u_B {r['peak_u_B_v']:.3g} V"
            f"  SNR u_B ~{r['snr_u_B_db']:.3g} dB, terminals ~{r['snr_terminals_db']:.3g} dB"
        )
