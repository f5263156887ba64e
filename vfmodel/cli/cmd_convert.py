"""``vfmodel convert IN OUT``: spectra between Touchstone and CSV."""

from __future__ import annotations

from pathlib import Path

import click

from vfmodel.core.atomic import check_output_place
from vfmodel.core.io_spectrum import read_spectrum, spectrum_format, write_spectrum
from vfmodel.errors import InputError


@click.command()
@click.argument("src", metavar="IN", type=click.Path(path_type=Path))
@click.argument("dst", metavar="OUT", type=click.Path(path_type=Path))
@click.option(
    "--kind",
    type=click.Choice(["Z", "Y", "S"]),
    default=None,
    help="Convert the network parameters (default: keep the input's).",
)
@click.option("--z0", type=float, default=None, help="Reference impedance for S output (ohm).")
def convert(src: Path, dst: Path, kind: str | None, z0: float | None) -> None:
    """Convert a spectrum between Touchstone (.sNp) and CSV; formats from the suffixes."""
    spectrum_format(dst)  # reject an unknown output type before reading anything
    if dst.resolve() == src.resolve():
        raise InputError("output would overwrite the input", source=str(dst))
    check_output_place(dst, "OUT", directory=False)
    data = read_spectrum(src)
    if kind is not None or z0 is not None:
        data = data.to_kind(kind or data.kind, z0=z0)  # type: ignore[arg-type]
    write_spectrum(dst, data)
    click.echo(
        f"wrote {dst}: {data.n_out}x{data.n_in} {data.kind}, {data.n_freq} points, "
        f"{data.freq_hz[0]:.6g}-{data.freq_hz[-1]:.6g} Hz"
    )
