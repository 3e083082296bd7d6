"""`unerode-cli synth OUT`: reproducible synthetic DEMs with a CRS."""

from __future__ import annotations

from enum import Enum
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import (
    Cog,
    CreationOptions,
    Dtype,
    DtypeOpt,
    OutputDem,
    Overwrite,
    Preview,
    Quiet,
    Seed,
    Verbose,
)
from unerode_cli.cli.values import Number


class Kind(str, Enum):
    fractal = "fractal"
    mountain = "mountain"


def synth(
    output: OutputDem,
    size: Annotated[int, typer.Option(help="Grid size in cells (square).", min=8, max=16384)] = 512,
    dx: Annotated[float, typer.Option("--dx", parser=Number("m", 0.0, above=True), help="Cell size (m, > 0).")] = 30.0,
    seed: Seed = 1,
    kind: Annotated[Kind, typer.Option(help="fractal noise, or a mountain range draining south to a sea edge.")] = Kind.mountain,
    relief: Annotated[float, typer.Option(parser=Number("m", 0.0), help="Land relief (m, ≥ 0).")] = 2000.0,
    crs: Annotated[str, typer.Option(help="CRS of the output (EPSG code, WKT or PROJ string).")] = "EPSG:32632",
    centre: Annotated[str | None, typer.Option(help="Centre X,Y in CRS units (lon,lat if geographic); default: the CRS's area of use.")] = None,
    sea_nodata: Annotated[bool, typer.Option("--sea-nodata", help="Make cells below 0 m nodata (a coastline clipped DEM).")] = False,
    dtype: DtypeOpt = Dtype.float32,
    cog: Cog = False,
    co: CreationOptions = None,
    overwrite: Overwrite = False,
    preview: Preview = None,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Generate a synthetic DEM (the same seed gives the same terrain)."""
    with reported_errors(verbose - quiet):
        from unerode_cli.jobs.synth import SynthJob, run_synth
        from unerode_cli.run.outputs import Outputs

        outputs = Outputs.from_cli(output, dtype.value, cog, co, overwrite, preview)
        run_synth(SynthJob(outputs, kind.value, size, dx, relief, seed, crs, centre, sea_nodata))
