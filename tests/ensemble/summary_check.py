"""The check that an ensemble's summary rasters are the NumPy statistics of its members'."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import rasterio

#: The statistics the ensemble writes for each raster all members write.
STATISTICS = ("mean", "std", "p5", "p50", "p95")


def read(path: Path) -> np.ndarray:
    """Band 1 of the raster at ``path``, float64."""
    with rasterio.open(path) as src:
        return src.read(1).astype(np.float64)


def assert_summaries_match_members(out: Path, stem: str, members: int) -> None:
    """Every summary/STEM_STAT.tif equals NumPy's statistic of members/000i/STEM.tif (rtol 1e-6,
    atol 1e-4 m) and is a cloud-optimised GeoTIFF on the members' grid."""
    stack = np.stack([read(out / "members" / f"{i:04d}" / f"{stem}.tif") for i in range(members)])
    expected = {"mean": stack.mean(axis=0), "std": stack.std(axis=0),
                **{f"p{q}": np.percentile(stack, q, axis=0) for q in (5, 50, 95)}}
    for name in STATISTICS:
        path = out / "summary" / f"{stem}_{name}.tif"
        np.testing.assert_allclose(read(path), expected[name], rtol=1e-6, atol=1e-4)
        with rasterio.open(path) as src, rasterio.open(out / "members/0000" / f"{stem}.tif") as member:
            assert src.crs == member.crs and src.transform == member.transform
            assert src.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"
