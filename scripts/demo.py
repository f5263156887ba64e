"""`make demo`: the deepest real job each stage of vfmodel can do, on the shipped data.

Runs the ``vfmodel`` commands in order and prints what they print; stops at the first
failure with its exit status.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import click

from vfmodel.cli.main import cli, main

REPO = Path(__file__).resolve().parents[1]


def _step(title: str, argv: list[str]) -> None:
    print(f"\n=== {title}\n$ vfmodel {' '.join(argv)}", flush=True)
    t0 = time.perf_counter()
    code = main(argv)
    print(f"(exit {code}, {time.perf_counter() - t0:.1f} s)", flush=True)
    if code != 0:
        sys.exit(code)


def available_commands() -> set[str]:
    """The CLI's commands (the group loads them lazily: ``cli.commands`` is empty until
    one runs, and the demo skipped fit and reproduce)."""
    return set(cli.list_commands(click.Context(cli)))


def run(out: Path) -> None:
    data = REPO / "data"
    agilent = data / "touchstone" / "Agilent_E5071B.s4p"
    bench = data / "pmsm40kw" if (data / "pmsm40kw").is_dir() else data / "small-example"
    _step("What a dataset holds", ["info", str(bench)])
    _step("Touchstone S-parameters -> Z-parameter CSV",
          ["convert", str(agilent), str(out / "agilent_z.csv"), "--kind", "Z"])
    commands = available_commands()
    if "fit" in commands:
        _step("Vector fit of a measured 4-port, passivity certified, SPICE export",
              ["fit", str(agilent), "--order", "auto", "--passive",
               "--spice", str(out / "agilent.cir"), "--out", str(out / "fit-agilent")])
    if "reproduce" in commands and (data / "pmsm40kw" / "dataset.toml").exists():
        _step("Grey-box bearing-voltage model of the 40-kW PMSM test bench",
              ["reproduce", str(data / "pmsm40kw"), "--out", str(out / "pmsm40kw")])
    print(f"\noutputs in {out}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=REPO / "demo-out")
    run(parser.parse_args().out)
