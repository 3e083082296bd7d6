"""The ``unerode-cli`` entry point. Start-up stays light: subcommand modules import numerical
and GIS libraries only when they run, so ``--help`` answers at once."""

from __future__ import annotations

import sys
from typing import Annotated

import typer
import typer.core
from typer.core import TyperGroup

from unerode_cli import __version__
from unerode_cli.cli.commands import register
from unerode_cli.cli.pipeline_cmd import pipeline_app

#: The click that parses the command line: typer's own copy where it has one, else click.
_parser_click = getattr(typer.core, "_click", None) or __import__("click")


class OneLineUsageErrors(TyperGroup):
    """The root group: a usage error (unknown option, missing argument, bad value) is one line on
    stderr, ``error: …; see 'unerode-cli erode -h'.``, exit 2, instead of a framed panel."""

    def main(self, *args, standalone_mode: bool = True, **kwargs):  # type: ignore[override]
        if not standalone_mode:
            return super().main(*args, standalone_mode=False, **kwargs)
        try:
            returned = super().main(*args, standalone_mode=False, **kwargs)
        except _parser_click.exceptions.UsageError as error:
            message = error.format_message().rstrip(".")
            message = message[:1].lower() + message[1:]
            where = f"; see '{error.ctx.command_path} -h'" if error.ctx is not None else ""
            typer.echo(f"error: {message}{where}.", err=True)
            sys.exit(error.exit_code)
        except _parser_click.exceptions.ClickException as error:
            typer.echo(f"error: {error.format_message().rstrip('.')}.", err=True)
            sys.exit(error.exit_code)
        except _parser_click.exceptions.Abort:
            typer.echo("error: aborted.", err=True)
            sys.exit(1)
        sys.exit(returned if isinstance(returned, int) else 0)


app = typer.Typer(
    name="unerode-cli",
    cls=OneLineUsageErrors,
    help="Erode terrains forward in time and unerode them backward (DEM toolchain).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)

register(app)
app.add_typer(pipeline_app, name="pipeline")


def versions() -> str:
    """Versions of unerode-cli and the libraries a bug report needs."""
    import numba
    import numpy

    from unerode_cli.io.versions import io_library_versions

    names = {"unerode-cli": __version__, "numpy": numpy.__version__, "numba": numba.__version__,
             **io_library_versions()}
    return "\n".join(f"{name:<11} {version}" if name != "unerode-cli" else f"{name} {version}"
                     for name, version in names.items())


def _print_version(value: bool) -> None:
    if value:
        typer.echo(versions())
        raise typer.Exit()


@app.callback()
def root(
    version: Annotated[bool, typer.Option("--version", callback=_print_version, is_eager=True,
                                          help="Print versions and exit.")] = False,
) -> None:
    """Erode terrains forward in time and unerode them backward (DEM toolchain)."""


def main() -> None:
    app()
