"""Options of `diff` (declared once: CLI, pipeline, Python API, provenance)."""

from __future__ import annotations

from pathlib import Path

from unerode_cli.run.common_options import GEOREF, RASTER_OUTPUT
from unerode_cli.run.declare import Opt

OPTIONS = (
    Opt("a", Path, help="First DEM (A), metres.", argument=True, required=True, role="input"),
    Opt("b", Path, help="Second DEM (B) on the same grid (shape, transform, CRS).", argument=True,
        required=True, role="input"),
    Opt("output", Path, help="Output raster of B − A (m): positive where B is higher.", argument=True,
        required=True, role="output", record=False),
    *GEOREF,
    *RASTER_OUTPUT,
)
