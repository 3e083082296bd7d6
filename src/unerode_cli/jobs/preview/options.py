"""Options of `preview` (declared once: CLI, pipeline, Python API)."""

from __future__ import annotations

from pathlib import Path

from unerode_cli.run.common_options import OVERWRITE, READING, SOURCE, renamed
from unerode_cli.run.declare import Opt
from unerode_cli.run.values import Number

OPTIONS = (
    renamed(SOURCE, "dem"),
    Opt("png", Path, help="Output PNG.", argument=True, required=True, role="output", record=False),
    Opt("title", str, None, "Title (default: the DEM's file name)."),
    Opt("cmap", str, "sea-land", "Colour map: sea-land (blues below 0 m) or any matplotlib one."),
    Opt("exaggeration", float, 1.0, "Vertical exaggeration of the hillshade (> 0).",
        parser=Number(minimum=0.0, above=True)),
    Opt("label", str, "elevation (m)", "Name of the colour bar, e.g. 'ice thickness (m)'."),
    *READING,
    OVERWRITE,
)
