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


class Kind(str, Enum):
    fractal = "fractal"
    mountain = "mountain"


def synth(
    output: OutputDem,
    size: Annotated[int, typer.Option(help="Grid size in cells (square).", min=8, max=16384)] = 512,
    dx: Annotated[float, typer.Option("--dx", help="Cell size (m).")] = 30.0,
    seed: Seed = 1,
    kind: Annotated[Kind, typer.Option(help="fractal noise, or a mountain range draining south to a sea edge.")] = Kind.mountain,
    relief: Annotated[float, typer.Option(help="Land relief (m).")] = 2000.0,
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
        import numpy as np

        from unerode_cli.errors import InputError
        from unerode_cli.pipeline.outputs import Outputs, save
        from unerode_cli.raster.cellsize import cell_size_metres
        from unerode_cli.raster.georef import centred_transform, parse_crs
        from unerode_cli.raster.terrain import Terrain
        from unerode_cli.synthetic import synthesize

        outputs = Outputs.from_cli(output, dtype.value, cog, co, overwrite, preview)
        outputs.check()
        if not dx > 0:
            raise InputError(f"--dx must be a positive cell size in metres, got {dx}.")
        crs_obj = parse_crs(crs)
        centre_xy = _parse_centre(centre)
        transform = centred_transform(crs_obj, (size, size), dx, centre_xy)
        elevation = synthesize(kind.value, (size, size), relief, seed)
        if sea_nodata:
            elevation = np.where(elevation < 0.0, np.nan, elevation)
        wkt = crs_obj.to_wkt()
        cell = cell_size_metres(wkt, transform, (size, size), str(output))
        terrain = Terrain(elevation, cell.dx, cell.dy, wkt, transform,
                          -9999.0 if sea_nodata else None, {"AREA_OR_POINT": "Area", "UNIT": "metre"})
        save(terrain, outputs, "synth",
             {"kind": kind.value, "size": size, "dx": dx, "relief": relief, "crs": crs,
              "centre": centre, "sea_nodata": sea_nodata}, seed=seed)


def _parse_centre(text: str | None) -> tuple[float, float] | None:
    from unerode_cli.errors import InputError

    if text is None:
        return None
    try:
        x, y = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"--centre expects X,Y (two numbers), got '{text}'.") from None
    return (x, y)
