"""OpenEXR heightfields: one float32 channel ``Y`` in metres, georeferencing in the header.

Header attributes (strings, so that doubles survive exactly):
``unerode.cellSize`` ("dx dy", m), ``unerode.transform`` (JSON list of the 6 affine
coefficients a, b, c, d, e, f), ``unerode.crsWkt``, ``unerode.nodata`` (JSON number or null),
``unerode.tags`` (JSON object of kept tags). A GeoTIFF → EXR → GeoTIFF trip is lossless for
float32 data.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import OpenEXR
from affine import Affine

from unerode_cli.errors import InputError
from unerode_cli.io.cellsize import check_north_up
from unerode_cli.io.gdal_io import output_nodata
from unerode_cli.io.terrain import Terrain

PREFIX = "unerode."
FLOAT_TYPES = (np.float16, np.float32)


def read_exr(path: Path, channel: str | None = None) -> Terrain:
    """Read a heightfield channel: ``channel`` if given, else Y, else R, else the only float one.

    Channels are read one by one (an RGB image gives R, G and B, never one grouped "RGB").
    """
    try:
        with OpenEXR.File(str(path), separate_channels=True) as exr:
            # The header mapping is only valid while the file is open: copy what is needed.
            attrs = {k[len(PREFIX):]: v for k, v in exr.header().items() if k.startswith(PREFIX)}
            channels = {name: ch.pixels for name, ch in exr.channels().items()}
    except Exception as exc:  # the bindings raise bare RuntimeError/OSError subclasses
        raise InputError(f"{path} is not an OpenEXR file that can be read ({exc}).") from None
    data = _pick_channel(channels, channel, path).astype(np.float64)
    if "transform" in attrs:
        transform = Affine(*json.loads(attrs["transform"]))
        check_north_up(transform, str(path))
        dx, dy = (float(v) for v in attrs["cellSize"].split())
    else:
        print(f"note: {path} carries no georeferencing; cells are taken to be 1 m.", file=sys.stderr)
        transform, dx, dy = Affine(1.0, 0.0, 0.0, 0.0, -1.0, float(data.shape[0])), 1.0, 1.0
    nodata = json.loads(attrs["nodata"]) if "nodata" in attrs else None
    invalid = ~np.isfinite(data)
    if nodata is not None:
        invalid |= data == np.float32(nodata)
    data[invalid] = np.nan
    tags = json.loads(attrs.get("tags", "{}"))
    return Terrain(data, dx, dy, attrs.get("crsWkt", ""), transform, nodata, tags)


def write_exr(terrain: Terrain, path: Path) -> None:
    """Write ``terrain`` as float32 channel Y with lossless ZIP compression."""
    nodata = output_nodata(terrain)
    fill = np.nan if nodata is None else nodata
    pixels = np.ascontiguousarray(np.where(terrain.nodata_mask, fill, terrain.elevation),
                                  dtype=np.float32)
    header = {
        "compression": OpenEXR.ZIP_COMPRESSION,
        "type": OpenEXR.scanlineimage,
        PREFIX + "cellSize": f"{terrain.dx!r} {terrain.dy!r}",
        PREFIX + "transform": json.dumps(list(terrain.transform)[:6]),
        PREFIX + "crsWkt": terrain.crs_wkt,
        PREFIX + "nodata": json.dumps(nodata),
        PREFIX + "tags": json.dumps(terrain.tags),
    }
    OpenEXR.File(header, {"Y": pixels}).write(str(path))


def _pick_channel(channels: dict[str, np.ndarray], wanted: str | None, path: Path) -> np.ndarray:
    if wanted is not None:
        if wanted not in channels:
            raise InputError(
                f"{path} has no channel '{wanted}' (it has: {', '.join(sorted(channels))})."
            )
        chosen = channels[wanted]
        if chosen.dtype not in FLOAT_TYPES:
            raise InputError(f"channel '{wanted}' of {path} is not a float channel.")
        return chosen
    floats = {n: c for n, c in channels.items() if c.dtype in FLOAT_TYPES}
    for name in ("Y", "R"):
        if name in floats:
            return floats[name]
    if len(floats) == 1:
        return next(iter(floats.values()))
    if not floats:
        raise InputError(f"{path} has no float channel to read as a heightfield.")
    raise InputError(
        f"{path} has several float channels ({', '.join(sorted(floats))}); choose one with --channel."
    )
