"""`unerode-cli convert IN OUT`: any supported heightfield format to any other."""

from __future__ import annotations

from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import (
    Band,
    Channel,
    Cog,
    CreationOptions,
    Dtype,
    DtypeOpt,
    InputDem,
    OutputDem,
    Overwrite,
    Preview,
    Quiet,
    Verbose,
)


def convert(
    source: InputDem,
    output: OutputDem,
    dtype: DtypeOpt = Dtype.float32,
    z_scale: Annotated[float, typer.Option("--z-scale", help="Multiply elevations by this factor (e.g. 0.3048 for feet → m).")] = 1.0,
    band: Band = None,
    channel: Channel = None,
    cog: Cog = False,
    co: CreationOptions = None,
    overwrite: Overwrite = False,
    preview: Preview = None,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Convert between GeoTIFF, EXR and other GDAL formats, keeping CRS, transform, nodata."""
    with reported_errors(verbose - quiet):
        from unerode_cli.cli.common import load
        from unerode_cli.errors import InputError
        from unerode_cli.run.outputs import Outputs, save

        outputs = Outputs.from_cli(output, dtype.value, cog, co, overwrite, preview)
        outputs.check(source)
        if not (z_scale > 0 and z_scale < float("inf")):
            raise InputError(f"--z-scale must be a positive finite factor, got {z_scale}.")
        terrain = load(source, band, channel)
        converted = terrain.with_elevation(terrain.elevation * z_scale)
        save(converted, outputs, "convert",
             {"input": source, "output": output, "dtype": dtype.value, "z_scale": z_scale})
