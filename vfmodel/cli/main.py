"""Entry point of the ``vfmodel`` command.

Exit status: 0 success, 2 bad input or usage, 1 internal failure (CONTRACT section 3).
Set ``VFMODEL_DEBUG=1`` to see the traceback of an internal failure.
"""

from __future__ import annotations

import os
import sys
import traceback

import click

from vfmodel import __version__
from vfmodel.cli.cmd_convert import convert
from vfmodel.cli.cmd_info import info
from vfmodel.errors import InputError, VfmodelError


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="vfmodel")
def cli() -> None:
    """vfmodel: passive rational macromodels and grey-box bearing-voltage models of
    inverter-fed electrical machines from measured high-frequency data."""


cli.add_command(info)
cli.add_command(convert)


def _register_optional() -> None:
    """Commands whose layers may be absent in a partial install are added when importable."""
    import importlib

    for module, name in (
        ("vfmodel.cli.cmd_fit", "fit"),
        ("vfmodel.cli.cmd_reproduce", "reproduce"),
        ("vfmodel.cli.cmd_diagnose", "diagnose"),
        ("vfmodel.cli.cmd_predict", "predict"),
    ):
        try:
            mod = importlib.import_module(module)
        except ModuleNotFoundError as err:
            if err.name == module:
                continue
            raise
        cli.add_command(getattr(mod, name))


_register_optional()


def _show_warning(message: Warning | str, category: type[Warning], filename: str,
                  lineno: int, file: object = None, line: str | None = None) -> None:
    click.echo(f"vfmodel: warning: {message}", err=True)


def main(argv: list[str] | None = None) -> int:
    """Run the CLI and return its exit status (used by the console script)."""
    import warnings

    with warnings.catch_warnings():
        warnings.showwarning = _show_warning
        return _main(argv)


def _main(argv: list[str] | None) -> int:
    try:
        cli.main(args=argv, prog_name="vfmodel", standalone_mode=False)
    except click.exceptions.Exit as ex:
        return int(ex.exit_code)
    except click.exceptions.Abort:
        click.echo("vfmodel: aborted", err=True)
        return 1
    except click.ClickException as ex:
        ex.show()
        return 2
    except InputError as ex:
        click.echo(f"vfmodel: error: {ex}", err=True)
        return 2
    except VfmodelError as ex:
        click.echo(f"vfmodel: failed: {ex}", err=True)
        return 1
    except KeyboardInterrupt:
        click.echo("vfmodel: interrupted", err=True)
        return 130
    except Exception as ex:  # an internal failure: say so, traceback only on request
        click.echo(f"vfmodel: internal error: {type(ex).__name__}: {ex}", err=True)
        if os.environ.get("VFMODEL_DEBUG"):
            traceback.print_exc()
        else:
            click.echo("(set VFMODEL_DEBUG=1 for the traceback)", err=True)
        return 1
    return 0


def entry() -> None:
    """Console-script wrapper."""
    sys.exit(main())


if __name__ == "__main__":  # pragma: no cover
    entry()
