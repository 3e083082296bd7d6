"""Heightfield rasters: the ``Terrain`` type and the only code that reads or writes them."""

from unerode_cli.raster.terrain import Terrain

__all__ = ["Terrain"]
