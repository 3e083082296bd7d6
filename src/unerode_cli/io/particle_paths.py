"""GeoJSON of sampled particle paths (``particle-erode --paths``), for QGIS and GDAL."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.io.paths import atomic_path
from unerode_cli.io.terrain import Terrain
from unerode_cli.particles import ParticlePath


def grid_to_map(dem: Terrain, cols: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Map coordinates (x, y) in the DEM's CRS of grid coordinates (cell centres at integers)."""
    x, y = dem.transform * (np.asarray(cols) + 0.5, np.asarray(rows) + 0.5)
    return np.asarray(x), np.asarray(y)


def path_features(paths: list[ParticlePath], dem: Terrain, per_iteration: int) -> dict[str, Any]:
    """A GeoJSON FeatureCollection of LineStrings (x, y map coordinates in the DEM's CRS, z m)
    with each particle's id, iteration, index, fate, and times since emission (s). Points are
    kept within the DEM's extent (a particle leaving the domain ends on its border), and a path
    of a single point (a particle that died where it started) repeats it."""
    features = []
    ny, nx = dem.shape
    # x, y to a thousandth of a cell (CRS units: metres or degrees), z to the millimetre
    digits = max(0, math.ceil(-math.log10(min(abs(dem.transform.a), abs(dem.transform.e)) / 1000.0)))
    for path in paths:
        pts = path.points if len(path.points) > 1 else np.repeat(path.points[:1], 2, axis=0)
        x, y = grid_to_map(dem, np.clip(pts[:, 0], -0.5, nx - 0.5), np.clip(pts[:, 1], -0.5, ny - 0.5))
        coords = np.column_stack([np.round(x, digits), np.round(y, digits), np.round(pts[:, 2], 3)]).tolist()
        features.append({
            "type": "Feature",
            "properties": {"id": path.iteration * per_iteration + path.index, "iteration": path.iteration,
                           "index": path.index, "fate": path.fate,
                           "duration_s": float(pts[-1, 3]), "times_s": np.round(pts[:, 3], 4).tolist()},
            "geometry": {"type": "LineString", "coordinates": coords},
        })
    collection: dict[str, Any] = {"type": "FeatureCollection", "name": "particle_paths"}
    epsg = _epsg(dem.crs_wkt)
    if epsg is not None:  # the pre-RFC 7946 member GDAL and QGIS read
        collection["crs"] = {"type": "name", "properties": {"name": f"urn:ogc:def:crs:EPSG::{epsg}"}}
    collection["features"] = features
    return collection


def write_paths(path: Path, paths: list[ParticlePath], dem: Terrain, per_iteration: int) -> None:
    """Write the sampled paths as GeoJSON (``path_features``), atomically."""
    payload = json.dumps(path_features(paths, dem, per_iteration), separators=(",", ":"))
    with atomic_path(path) as tmp:
        tmp.write_text(payload + "\n", encoding="utf-8")


def _epsg(crs_wkt: str) -> int | None:
    if not crs_wkt:
        return None
    from pyproj import CRS

    return CRS.from_wkt(crs_wkt).to_epsg()
