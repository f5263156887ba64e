"""``vfmodel info DATASET|FILE``: what a dataset or a single spectrum file holds."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from vfmodel.cli._common import finite_json


@click.command()
@click.argument("dataset", metavar="DATASET|FILE", type=click.Path(path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def info(dataset: Path, as_json: bool) -> None:
    """Topologies, frequency ranges, recordings, sample rates, durations and SNR estimates
    of a dataset; or, for a single Touchstone/CSV file, its kind, ports, points, range,
    noise estimate and passivity violation floor."""
    if dataset.is_file():
        _info_file(dataset, as_json)
        return
    from vfmodel.core.io_dataset import read_dataset
    from vfmodel.pipeline.summary import dataset_summary

    ds = read_dataset(dataset)
    if ds.prior_overrides:  # names of grey-box parameters (exit 2 for an unknown one)
        from vfmodel.greybox.priors import check_overrides

        check_overrides(ds)
    summary = dataset_summary(ds)
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
        click.echo(_spectrum_line(topo, s))
    if summary["further_impedance"] or summary["impedance_at_speed"]:
        n = len(summary["further_impedance"]) + len(summary["impedance_at_speed"])
        click.echo(f"further impedance spectra (CONTRACT 2a): {n}")
        for topo, s in summary["further_impedance"].items():
            click.echo(_spectrum_line(f"{topo} at standstill", s))
        for s in summary["impedance_at_speed"]:
            click.echo(_spectrum_line(f"{s['topology']} at {s['speed_rpm']:g} rpm", s))
    click.echo(f"recordings: {len(summary['recordings'])}")
    for r in summary["recordings"]:
        click.echo(
            f"  {r['speed_rpm']:6g} rpm  fs {r['fs_hz'] / 1e6:g} MS/s  {r['n_samples']} samples"
            f"  {r['duration_s'] * 1e3:.4g} ms  raw peak u_B {r['peak_u_B_v']:.3g} V"
            f"  SNR u_B ~{r['snr_u_B_db']:.3g} dB, terminals ~{r['snr_terminals_db']:.3g} dB"
        )
        if r["extra_channels"]:
            extra = []
            if r["peak_u_B_DE_v"] is not None:
                extra.append(f"u_B_DE (raw peak {r['peak_u_B_DE_v']:.3g} V)")
            if r["rms_i_CM_a"] is not None:
                extra.append(f"i_CM (rms {r['rms_i_CM_a']:.3g} A)")
            click.echo(f"           further channels: {', '.join(extra)}")
    for table in ("machine", "bearing"):
        if summary[table]:
            items = ", ".join(f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}"
                              for k, v in summary[table].items())
            click.echo(f"[{table}]: {items}")
    for name, ov in summary["prior_overrides"].items():
        click.echo(f"[priors] {name}: " + ", ".join(f"{k} {v:g}" for k, v in ov.items()))


def _spectrum_line(label: str, s: dict[str, Any]) -> str:
    return (f"  {label:8s} {s['n_points']:5d} points  {s['f_min_hz']:10.4g} - "
            f"{s['f_max_hz']:10.4g} Hz   |Z| {s['z_min_ohm']:.4g} - {s['z_max_ohm']:.4g} ohm"
            f"   noise ~{s['noise_pct']:.2g} %")


def _info_file(path: Path, as_json: bool) -> None:
    """``info FILE``: one spectrum (Touchstone or CSV)."""
    from vfmodel.core.io_spectrum import read_spectrum
    from vfmodel.pipeline.fit_job import spectrum_summary

    s: dict[str, Any] = spectrum_summary(read_spectrum(path))
    if as_json:
        click.echo(json.dumps(finite_json(s), indent=2, allow_nan=False))
        return
    n_out, n_in = s["ports"]
    z0 = f", z0 {s['z0_ohm']:g} ohm" if s["z0_ohm"] is not None else ""
    click.echo(f"{path}: {s['kind']} {n_out}x{n_in}{z0}, {s['n_points']} points "
               f"{s['f_min_hz']:.6g} - {s['f_max_hz']:.6g} Hz ({s['spacing']})")
    click.echo(f"  ||H(f)|| {s['norm_min']:.4g} - {s['norm_max']:.4g}"
               + (f", noise ~{100 * s['noise_rel']:.2g} % per point"
                  if s["noise_rel"] is not None else ""))
    if s["artifacts"]:
        click.echo(f"  artifacts: {s['artifacts']}")
    if s["passivity_floor"] is not None:
        click.echo(f"  passivity violation floor {s['passivity_floor']:.3g} (largest "
                   f"violation {s['worst_violation']:.3g})"
                   + ("; ACTIVE data" if s["active"] else ""))
