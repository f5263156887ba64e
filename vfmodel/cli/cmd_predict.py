"""``vfmodel predict MODEL RECORDING|--inverter KEY=VALUE,... --out DIR`` (CONTRACT 3)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from vfmodel.cli._common import out_option, progress_bar, quiet_option, write_json
from vfmodel.errors import InputError

if TYPE_CHECKING:
    from vfmodel.circuit.netlist import Circuit

MAX_MODEL_NODES = 500
"""Largest model netlist predict solves (every frequency of the record is one MNA solve)."""
PREDICT_OUTPUTS = ("prediction.npz", "prediction.json", "prediction.png")
"""Outputs of ``predict`` in DIR (an earlier run's are replaced, never mixed)."""


def _parse_inverter(text: str) -> dict[str, float]:
    out: dict[str, float] = {}
    for item in text.split(","):
        if not item.strip():
            continue
        if "=" not in item:
            raise InputError("inverter option must be KEY=VALUE", place="--inverter",
                             found=repr(item))
        k, v = item.split("=", 1)
        if k.strip() in out:
            raise InputError("inverter option given twice", source="--inverter",
                             place=k.strip())
        try:
            out[k.strip()] = float(v)
        except ValueError:
            raise InputError("inverter option value must be a number", place=k.strip(),
                             found=repr(v)) from None
    return out


@click.command()
@click.argument("model", type=click.Path(path_type=Path))
@click.argument("recording", type=click.Path(path_type=Path), required=False)
@click.option("--inverter", default=None, metavar="KEY=VALUE,...",
              help="Inverter description instead of a recording, e.g. "
                   "'v_dc=270,f_sw_hz=8000,speed_rpm=300' (keys: see the docs of "
                   "vfmodel.pipeline.predict.inverter_options).")
@out_option
@quiet_option
def predict(model: Path, recording: Path | None, inverter: str | None, out_dir: Path,
            quiet: bool) -> None:
    """Bearing voltage predicted by an identified model (MODEL: a network_<rpm>rpm.cir
    written by 'vfmodel reproduce') for the terminal voltages of RECORDING or for an
    inverter description. Writes DIR/prediction.npz, DIR/prediction.json and
    DIR/prediction.png."""
    import numpy as np

    from vfmodel.core.atomic import atomic_path, staged_output
    from vfmodel.core.io_recording import read_recording
    from vfmodel.pipeline.predict import (
        check_inverter_options,
        predict_inverter,
        predict_recording,
    )
    from vfmodel.report.predict_figures import plot_prediction

    if (recording is None) == (inverter is None):
        raise click.UsageError("give either RECORDING or --inverter")
    options = None
    if inverter is not None:
        options = _parse_inverter(inverter)
        check_inverter_options(options)
    with staged_output(out_dir, owned=PREDICT_OUTPUTS) as stage:
        circ = read_model_netlist(model)
        prog = progress_bar(quiet)
        prog("predict", 0, 1)
        if recording is not None:
            pred = predict_recording(circ, read_recording(recording))
        else:
            pred = predict_inverter(circ, options or {})
        prog("predict", 1, 1)
        arrays = {"fs": np.float64(pred.fs), "u_U": pred.terminals[0],
                  "u_V": pred.terminals[1], "u_W": pred.terminals[2], "u_B": pred.u_b}
        if pred.u_b_measured is not None:
            arrays["u_B_measured"] = pred.u_b_measured
        with atomic_path(stage.path("prediction.npz")) as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)
        plot_prediction(pred, stage.path("prediction.png"))
        summary = {**pred.summary, "model": str(model),
                   "excitation": str(recording) if recording is not None else inverter}
        write_json(stage.path("prediction.json"), summary)
    click.echo(f"predicted peak bearing voltage {pred.summary['peak_model_v']:.4g} V; "
               f"wrote {out_dir / 'prediction.json'}")


def read_model_netlist(model: Path) -> Circuit:
    """The model netlist as a checked Circuit; InputError naming the file otherwise."""
    from vfmodel.circuit.spice_import import from_spice
    from vfmodel.core.text import read_text_file
    from vfmodel.errors import CircuitError
    from vfmodel.pipeline.predict import check_model_nodes

    text = read_text_file(model, "model netlist")
    try:
        circ = from_spice(text, source=str(model))
        circ.check()
    except CircuitError as err:
        msg = str(err)
        if not msg.startswith(str(model)):
            msg = f"{model}: {msg}"
        raise InputError(msg) from None
    check_model_nodes(circ, str(model))
    if len(circ.nodes) > MAX_MODEL_NODES:
        raise InputError("model netlist too large for predict", source=str(model),
                         found=f"{len(circ.nodes)} nodes",
                         expected=f"at most {MAX_MODEL_NODES} (a grey-box network has ~50)")
    return circ
