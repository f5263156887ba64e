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
from vfmodel.core.blas import blas_threads, limited_blas
from vfmodel.errors import InputError, VfmodelError

_COMMANDS = {
    "info": "vfmodel.cli.cmd_info",
    "convert": "vfmodel.cli.cmd_convert",
    "fit": "vfmodel.cli.cmd_fit",
    "reproduce": "vfmodel.cli.cmd_reproduce",
    "diagnose": "vfmodel.cli.cmd_diagnose",
    "predict": "vfmodel.cli.cmd_predict",
    "batch": "vfmodel.cli.cmd_batch",
}


class _LazyGroup(click.Group):
    """Commands imported when used (``--help`` and ``info`` start without scipy.signal,
    matplotlib, cvxpy or scikit-rf; the command modules import those inside)."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return list(_COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        import importlib

        module = _COMMANDS.get(cmd_name)
        if module is None:
            return None
        cmd = getattr(importlib.import_module(module), cmd_name)
        assert isinstance(cmd, click.Command)
        return cmd


@click.group(cls=_LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="vfmodel")
def cli() -> None:
    """vfmodel: passive rational macromodels and grey-box bearing-voltage models of
    inverter-fed electrical machines from measured high-frequency data."""


def _show_warning(message: Warning | str, category: type[Warning], filename: str,
                  lineno: int, file: object = None, line: str | None = None) -> None:
    click.echo(f"vfmodel: warning: {message}", err=True)


def main(argv: list[str] | None = None) -> int:
    """Run the CLI and return its exit status (used by the console script).

    BLAS threads are capped (:func:`blas_threads`): through the environment for the
    libraries loaded from now on (numpy's and scipy's OpenBLAS are separate) and with
    threadpoolctl for those already loaded; both are restored on return. Large freed
    arrays stay in the heap (:func:`vfmodel.core.allocator.keep_large_blocks`).
    """
    import warnings

    from vfmodel.core.allocator import keep_large_blocks

    keep_large_blocks()

    from vfmodel.errors import VfmodelWarning

    with warnings.catch_warnings(), limited_blas(blas_threads()):
        warnings.showwarning = _show_warning
        # vfmodel's own warnings are printed, whatever filters the interpreter runs with
        # (under "-W error" a warning of the fit became "internal error", exit 1)
        warnings.filterwarnings("always", category=VfmodelWarning)
        return _main(argv)


def _main(argv: list[str] | None) -> int:
    try:
        cli.main(args=argv, prog_name="vfmodel", standalone_mode=False)
    except click.exceptions.Exit as ex:
        return int(ex.exit_code)
    except click.exceptions.Abort:  # click turns KeyboardInterrupt into Abort
        click.echo("vfmodel: interrupted", err=True)
        return 130
    except click.UsageError as ex:  # one line, like every other bad input
        where = f" (see 'vfmodel {ex.ctx.command_path.partition(' ')[2] or ''} --help')" \
            if ex.ctx is not None else ""
        msg = " ".join(ex.format_message().split())
        click.echo(f"vfmodel: error: {msg}{where.replace('  ', ' ')}", err=True)
        return 2
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
    """Console-script wrapper (see :mod:`vfmodel.cli._entry` for the installed one)."""
    sys.exit(main())


if __name__ == "__main__":  # pragma: no cover
    entry()
