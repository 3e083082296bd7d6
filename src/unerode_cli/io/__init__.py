"""The only package that opens files: heightfield rasters (the ``Terrain`` type, GeoTIFF/GDAL,
EXR), rasters on a DEM's grid, tables, YAML, JSON, GeoJSON, checkpoints and provenance."""

from unerode_cli.io.terrain import Terrain

__all__ = ["Terrain"]
