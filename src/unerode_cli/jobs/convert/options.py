"""Options of `convert` (declared once: CLI, pipeline, Python API, provenance)."""

from __future__ import annotations

from unerode_cli.run.common_options import (
    BAND,
    CHANNEL,
    COG,
    CREATION_OPTIONS,
    DTYPE,
    GEOREF_CONVERT,
    OUTPUT,
    OVERWRITE,
    PREVIEW,
    SOURCE,
)
from unerode_cli.run.declare import Opt
from unerode_cli.run.values import Number, Numbers

POSITIVE = Number(minimum=0.0, above=True)

OPTIONS = (
    SOURCE,
    OUTPUT,
    DTYPE,
    Opt("z_scale", float, 1.0, "Multiply elevations by this factor (> 0; e.g. 0.3048 for feet → m).",
        parser=POSITIVE),
    Opt("crop", str, None, "Keep the cells whose centres lie in this box (the DEM's CRS units).",
        parser=Numbers("XMIN,YMIN,XMAX,YMAX: four numbers in the DEM's CRS units", 4),
        metavar="XMIN,YMIN,XMAX,YMAX"),
    Opt("cell_size", float, None, "Resample to square cells of this size (the CRS's units; after --crop): "
        "averages when coarser, bilinear when finer.", parser=POSITIVE),
    BAND,
    CHANNEL,
    *GEOREF_CONVERT,
    COG,
    CREATION_OPTIONS,
    OVERWRITE,
    PREVIEW,
)
