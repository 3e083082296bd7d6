"""`unerode-cli convert IN OUT`: any supported heightfield format to any other."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.convert.options import OPTIONS

convert = command("unerode_cli.jobs.convert.job:ConvertJob",
                  "Convert between GeoTIFF, EXR and other GDAL formats, keeping CRS, transform, nodata; "
                  "optionally crop to a box and resample to another cell size.", options=OPTIONS)
