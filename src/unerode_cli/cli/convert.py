"""`unerode-cli convert IN OUT`: any supported heightfield format to any other."""

from __future__ import annotations

from typing import Annotated, Any

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
from unerode_cli.cli.values import Number, Numbers


def convert(
    source: InputDem,
    output: OutputDem,
    dtype: DtypeOpt = Dtype.float32,
    z_scale: Annotated[float, typer.Option("--z-scale", parser=Number(minimum=0.0, above=True), help="Multiply elevations by this factor (> 0; e.g. 0.3048 for feet → m).")] = 1.0,
    crop: Annotated[Any, typer.Option("--crop", parser=Numbers("XMIN,YMIN,XMAX,YMAX: four numbers in the DEM's CRS units", 4), metavar="XMIN,YMIN,XMAX,YMAX", help="Keep the cells whose centres lie in this box (the DEM's CRS units).")] = None,
    cell_size: Annotated[float | None, typer.Option("--cell-size", parser=Number(minimum=0.0, above=True), help="Resample to square cells of this size (the CRS's units; after --crop): averages when coarser, bilinear when finer.")] = None,
    band: Band = None,
    channel: Channel = None,
    cog: Cog = False,
    co: CreationOptions = None,
    overwrite: Overwrite = False,
    preview: Preview = None,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Convert between GeoTIFF, EXR and other GDAL formats, keeping CRS, transform, nodata;
    optionally crop to a box and resample to another cell size."""
    with reported_errors(verbose - quiet):
        from unerode_cli.cli.common import load
        from unerode_cli.io.resampling import crop as crop_to
        from unerode_cli.io.resampling import resample
        from unerode_cli.run.outputs import Outputs, save

        outputs = Outputs.from_cli(output, dtype.value, cog, co, overwrite, preview)
        outputs.check(source)
        terrain = load(source, band, channel)
        if crop is not None:
            terrain = crop_to(terrain, crop)
        if cell_size is not None:
            terrain = resample(terrain, cell_size)
        outputs.check_source(terrain, source)
        converted = terrain.with_elevation(terrain.elevation * z_scale)
        save(converted, outputs, "convert",
             {"input": source, "output": output, "dtype": dtype.value, "z_scale": z_scale,
             "crop": crop, "cell_size": cell_size})
