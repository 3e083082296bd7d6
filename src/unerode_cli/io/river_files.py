"""Reading a river line: GeoJSON (LineString or MultiLineString geometry, Feature or
FeatureCollection: the first line in it) or WKT (LINESTRING, MULTILINESTRING), coordinates in
the DEM's CRS. A multi-line is joined part after part, in file order."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from unerode_cli.errors import InputError

_WKT = re.compile(r"^\s*(MULTI)?LINESTRING\s*(Z|M|ZM)?\s*\((.*)\)\s*$", re.IGNORECASE | re.DOTALL)


def read_river_line(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) vertices (CRS units) of the river line in ``path`` (.geojson/.json or WKT text).

    Raises:
        InputError: unreadable file, no line in it, or fewer than two vertices.
    """
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or type(exc).__name__
        raise InputError(f"cannot read the river line {path}: {reason}.") from None
    vertices = _from_geojson(text, path) if text.lstrip().startswith("{") else _from_wkt(text, path)
    if len(vertices) < 2:
        raise InputError(f"the river line in {path} has fewer than two vertices.")
    xy = np.asarray(vertices, dtype=np.float64)
    if not np.isfinite(xy).all():
        raise InputError(f"the river line in {path} has non-finite coordinates.")
    return xy[:, 0], xy[:, 1]


def _from_geojson(text: str, path: Path) -> list[list[float]]:
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{path} is not valid GeoJSON: {exc.msg} (line {exc.lineno}).") from None
    for geometry in _geometries(data):
        kind, coords = geometry.get("type"), geometry.get("coordinates")
        try:
            if kind == "LineString":
                return [[float(c[0]), float(c[1])] for c in coords]
            if kind == "MultiLineString":
                return [[float(c[0]), float(c[1])] for part in coords for c in part]
        except (TypeError, IndexError, ValueError):
            raise InputError(f"{path}: the {kind} has malformed coordinates.") from None
    raise InputError(f"{path} holds no LineString or MultiLineString.")


def _geometries(data: object):
    """Geometries of a GeoJSON object, in file order."""
    if not isinstance(data, dict):
        return
    kind = data.get("type")
    if kind == "FeatureCollection":
        for feature in data.get("features") or []:
            yield from _geometries(feature)
    elif kind == "Feature":
        yield from _geometries(data.get("geometry"))
    elif kind == "GeometryCollection":
        for geometry in data.get("geometries") or []:
            yield from _geometries(geometry)
    elif isinstance(data.get("coordinates"), list):
        yield data


def _from_wkt(text: str, path: Path) -> list[list[float]]:
    match = _WKT.match(text)
    if match is None:
        raise InputError(f"{path} is neither GeoJSON nor a WKT LINESTRING/MULTILINESTRING.")
    body = match.group(3).replace("(", " ").replace(")", ",")
    vertices = []
    for point in body.split(","):
        numbers = point.split()
        if not numbers:
            continue
        try:
            vertices.append([float(numbers[0]), float(numbers[1])])
        except (ValueError, IndexError):
            raise InputError(f"{path}: malformed WKT vertex '{point.strip()}'.") from None
    return vertices
