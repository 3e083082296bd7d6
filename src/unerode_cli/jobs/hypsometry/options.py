"""Options of `hypsometry` (declared once: CLI, pipeline, Python API)."""

from __future__ import annotations

from pathlib import Path

from unerode_cli.run.common_options import GEOREF, OVERWRITE
from unerode_cli.run.declare import Opt

OPTIONS = (
    Opt("dems", Path, help="One or more DEMs (GeoTIFF, any GDAL raster, or .exr), metres.", kind="multiple",
        argument=True, required=True, role="input"),
    Opt("csv", Path, None, "Write the histograms here: one row per DEM and bin.", role="output"),
    Opt("plot", Path, None, "Write the curves of all DEMs on one PNG.", role="output"),
    Opt("bins", int, 50, "Number of elevation bins.", minimum=1),
    Opt("normalise", str, "max", "max: elevation / highest elevation (001 Fig. 15); range: (h − min)/(max − "
        "min) (Strahler); none: metres.", choices=("max", "range", "none")),
    *GEOREF,
    OVERWRITE,
)
