"""Shared fixtures: running the CLI as a user does, and small rasters written on the fly."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
SAMPLE_DEMS = Path(__file__).resolve().parents[1] / "sample_dems"


def run_cli(*args: object, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """Run ``unerode-cli ARGS`` in a fresh interpreter; returns the completed process."""
    return subprocess.run(
        [sys.executable, "-m", "unerode_cli", *map(str, args)],
        capture_output=True, text=True, cwd=cwd, timeout=300,
    )


@pytest.fixture
def cli():
    return run_cli


def write_geotiff(path: Path, data: np.ndarray, transform: Affine | None = None,
                  crs: str | None = "EPSG:32632", nodata: float | None = None) -> Path:
    """Write a plain single-band GeoTIFF for tests (no unerode-cli code involved)."""
    transform = transform or Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)
    with rasterio.open(path, "w", driver="GTiff", height=data.shape[0], width=data.shape[1],
                       count=1, dtype=data.dtype, crs=crs, transform=transform,
                       nodata=nodata) as dst:
        dst.write(data, 1)
    return path


@pytest.fixture
def small_dem(tmp_path: Path) -> Path:
    """A 40 × 50 projected float32 DEM (UTM 32N, 30 m) with a nodata hole."""
    rng = np.random.default_rng(0)
    data = (1000.0 + 100.0 * rng.random((40, 50))).astype(np.float32)
    data[5:9, 10:14] = -9999.0
    return write_geotiff(tmp_path / "dem.tif", data, nodata=-9999.0)
