"""The ``unerode-cli`` entry point. Start-up stays light: subcommand modules import numerical
and GIS libraries only when they run, so ``--help`` answers at once."""

from __future__ import annotations

from typing import Annotated

import typer

from unerode_cli import __version__
from unerode_cli.cli.commands import register
from unerode_cli.cli.pipeline_cmd import pipeline_app

app = typer.Typer(
    name="unerode-cli",
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
