"""The ``unerode-cli`` entry point. Start-up stays light: subcommand modules import numerical
and GIS libraries only when they run, so ``--help`` answers at once."""

from __future__ import annotations

from typing import Annotated

import typer

from unerode_cli import __version__
from unerode_cli.cli.climate_run import climate_run
from unerode_cli.cli.compare_terraces import compare_terraces
from unerode_cli.cli.convert import convert
from unerode_cli.cli.diff import diff
from unerode_cli.cli.erode import erode, unerode
from unerode_cli.cli.flow import flow
from unerode_cli.cli.glaciate import glaciate
from unerode_cli.cli.hypsometry import hypsometry
from unerode_cli.cli.info import info
from unerode_cli.cli.particle_erode import particle_erode
from unerode_cli.cli.pipeline_cmd import pipeline_app
from unerode_cli.cli.preview import preview
from unerode_cli.cli.synth import synth

app = typer.Typer(
    name="unerode-cli",
    help="Erode terrains forward in time and unerode them backward (DEM toolchain).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)

for command in (info, convert, preview, synth, flow, erode, unerode, diff, hypsometry, glaciate):
    app.command()(command)
app.command("climate-run")(climate_run)
app.command("compare-terraces")(compare_terraces)
app.command("particle-erode")(particle_erode)
app.add_typer(pipeline_app, name="pipeline")


def versions() -> str:
    """Versions of unerode-cli and the libraries a bug report needs."""
    import numba
    import numpy
    import OpenEXR
    import pyproj
    import rasterio

    return "\n".join([
        f"unerode-cli {__version__}",
        f"numpy       {numpy.__version__}",
        f"numba       {numba.__version__}",
        f"rasterio    {rasterio.__version__}",
        f"GDAL        {rasterio.__gdal_version__}",
        f"PROJ        {pyproj.proj_version_str}",
        f"OpenEXR     {OpenEXR.__version__}",
    ])


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
