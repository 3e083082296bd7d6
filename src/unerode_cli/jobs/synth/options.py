"""Options of `synth` (declared once: CLI, pipeline, Python API, provenance)."""

from __future__ import annotations

import dataclasses

from unerode_cli.run.common_options import OUTPUT, RASTER_OUTPUT, SEED
from unerode_cli.run.declare import Opt
from unerode_cli.run.values import Number

OPTIONS = (
    OUTPUT,
    Opt("size", int, 512, "Grid size in cells (square).", minimum=8, maximum=16384),
    Opt("dx", float, 30.0, "Cell size (m, > 0).", parser=Number("m", 0.0, above=True)),
    # the seed is recorded as the history entry's seed, not among the parameters
    dataclasses.replace(SEED, default=1, record=False),
    Opt("kind", str, "mountain", "fractal noise, or a mountain range draining south to a sea edge.",
        choices=("fractal", "mountain")),
    Opt("relief", float, None, "Land relief (m, ≥ 0); default: 2000 m, or less where the extent would make "
        "the land's median slope steeper than 30° (as real mountain ranges).", parser=Number("m", 0.0)),
    Opt("crs", str, "EPSG:32632", "CRS of the output (EPSG code, WKT or PROJ string)."),
    Opt("centre", str, None, "Centre X,Y in CRS units (lon,lat if geographic); default: the CRS's area "
        "of use."),
    Opt("sea_nodata", bool, False, "Make cells below 0 m nodata (a coastline clipped DEM).", kind="flag"),
    *RASTER_OUTPUT,
)
