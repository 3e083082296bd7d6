"""`unerode-cli info DEM`: size, CRS, cell size in metres, extent, elevation statistics."""

from __future__ import annotations

import json
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import Band, Channel, InputDem, Quiet, Verbose


def info(
    dem: InputDem,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of text.")] = False,
    band: Band = None,
    channel: Channel = None,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Describe a heightfield: size, CRS, cell size (m), extent, elevations (m), nodata."""
    with reported_errors(verbose - quiet):
        from unerode_cli.jobs.info import as_text, describe

        summary = describe(dem, band, channel)
        typer.echo(json.dumps(summary, indent=2) if as_json else as_text(summary))
