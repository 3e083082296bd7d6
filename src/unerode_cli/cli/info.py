"""`unerode-cli info DEM`: size, CRS, cell size in metres, extent, elevation statistics."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.info.options import OPTIONS

info = command("unerode_cli.jobs.info.job:InfoJob",
               "Describe a heightfield: size, CRS, cell size (m), extent, elevations (m), nodata.",
               options=OPTIONS)
