"""Options of `landforms` (declared once: CLI, pipeline, Python API)."""

from __future__ import annotations

from pathlib import Path

from unerode_cli.run.common_options import GEOREF, OUTLETS, OVERWRITE, SOURCE, renamed
from unerode_cli.run.declare import Opt
from unerode_cli.run.values import Number

MEASURES = "Measures"
POSITIVE_METRES = Number("m", 0.0, above=True)
METRES_AT_LEAST_0 = Number("m", 0.0)

OPTIONS = (
    renamed(SOURCE, "dem"),
    Opt("out", Path, help="Write landforms.json and landforms.png in this folder (created if missing).",
        required=True, role="output"),
    Opt("before", Path, None, "The DEM before erosion (any grid): its hypsometry is compared with DEM's.",
        role="input"),
    Opt("spacing", float, 500.0,
        "Distance between cross-sections along the trunk (m; at least the cell size).",
        parser=POSITIVE_METRES, panel=MEASURES),
    Opt("half_width", float, 2000.0, "Cross-sections reach this far on each side of the trunk (m).",
        parser=POSITIVE_METRES, panel=MEASURES),
    Opt("reach", float, 250.0, "Tributary steps are measured over their last reach of this length (m).",
        parser=POSITIVE_METRES, panel=MEASURES),
    Opt("min_step", float, 20.0, "A tributary whose step reaches this (m) is hanging.",
        parser=METRES_AT_LEAST_0, panel=MEASURES),
    Opt("min_lake_depth", float, 0.5, "A lake is deeper than this somewhere (m); shallower pits are DEM "
        "noise.", parser=METRES_AT_LEAST_0, panel=MEASURES),
    OUTLETS,
    *GEOREF,
    OVERWRITE,
)
