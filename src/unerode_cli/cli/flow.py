"""`unerode-cli flow DEM OUT`: discharge, drainage area or D8 receivers of a DEM."""

from __future__ import annotations

from enum import Enum
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import (
    Band,
    Channel,
    Cog,
    CreationOptions,
    Dirichlet,
    InputDem,
    Method,
    Outlets,
    OutputDem,
    Overwrite,
    Preview,
    Quiet,
    SeaLevel,
    Verbose,
)


class What(str, Enum):
    discharge = "discharge"
    area = "area"
    receivers = "receivers"


def flow(
    dem: InputDem,
    output: OutputDem,
    what: Annotated[What, typer.Option(help="discharge (m³/y), drainage area (m²), or receivers (ESRI D8 codes: E 1, SE 2, S 4, SW 8, W 16, NW 32, N 64, NE 128; 0 outlet).")] = What.discharge,
    method: Annotated[Method, typer.Option(help="mfd: multiple flow directions ∝ slope; d8: steepest descent.")] = Method.mfd,
    precipitation: Annotated[str, typer.Option("--precipitation", "-p", help="Precipitation rate (m/y): a number or a raster on the DEM's grid.")] = "1.0",
    outlets: Outlets = "all",
    sea_level: SeaLevel = None,
    dirichlet: Dirichlet = None,
    band: Band = None,
    channel: Channel = None,
    cog: Cog = False,
    co: CreationOptions = None,
    overwrite: Overwrite = False,
    preview: Preview = None,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Route water over a DEM (depressions are routed across, the DEM is not changed)."""
    with reported_errors(verbose - quiet):
        from unerode_cli.jobs.flow import FlowJob, output_dtype, run_flow
        from unerode_cli.run.outputs import Outputs

        outputs = Outputs.from_cli(output, output_dtype(what.value), cog, co, overwrite, preview)
        run_flow(FlowJob(dem, outputs, what.value, method.value, precipitation, outlets, sea_level,
                         dirichlet, band, channel))
