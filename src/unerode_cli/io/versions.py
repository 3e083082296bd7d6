"""Versions of the libraries that read and write files (what a bug report needs)."""

from __future__ import annotations


def io_library_versions() -> dict[str, str]:
    """Name → version of rasterio, the GDAL and PROJ it uses, and OpenEXR."""
    import OpenEXR
    import pyproj
    import rasterio

    return {"rasterio": rasterio.__version__, "GDAL": rasterio.__gdal_version__,
            "PROJ": pyproj.proj_version_str, "OpenEXR": OpenEXR.__version__}
