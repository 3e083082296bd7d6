"""OpenEXR heightfields: one float32 channel ``Y`` in metres, georeferencing in the header.

Header attributes (strings, so that doubles survive exactly):
``unerode.cellSize`` ("dx dy", m), ``unerode.transform`` (JSON list of the 6 affine
coefficients a, b, c, d, e, f), ``unerode.crsWkt``, ``unerode.nodata`` (JSON number or null),
``unerode.tags`` (JSON object of kept tags). A GeoTIFF → EXR → GeoTIFF trip is lossless for
float32 data.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
from collections.abc import Iterator
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
        with _library_messages_silenced(), OpenEXR.File(str(path), separate_channels=True) as exr:
            # The header mapping is only valid while the file is open: copy what is needed.
            attrs = {k[len(PREFIX):]: v for k, v in exr.header().items() if k.startswith(PREFIX)}
            channels = {name: ch.pixels for name, ch in exr.channels().items()}
    except Exception as exc:  # the bindings raise bare RuntimeError/OSError subclasses
        detail = str(exc).strip().splitlines()[0].rstrip(".") if str(exc).strip() else "unreadable"
        raise InputError(f"{path} is not an OpenEXR file that can be read, or it is damaged "
                         f"({detail}).") from None
    data = _pick_channel(channels, channel, path).astype(np.float64)
    if "transform" in attrs:
        transform = Affine(*_attribute(attrs, "transform", _parse_transform, path))
        check_north_up(transform, str(path))
        if "cellSize" in attrs:
            dx, dy = _attribute(attrs, "cellSize", _parse_cell_size, path)
        else:
            dx, dy = abs(transform.a), abs(transform.e)
    else:
        print(f"note: {path} carries no georeferencing; cells are taken to be 1 m.", file=sys.stderr)
        transform, dx, dy = Affine(1.0, 0.0, 0.0, 0.0, -1.0, float(data.shape[0])), 1.0, 1.0
    nodata = _attribute(attrs, "nodata", _parse_nodata, path) if "nodata" in attrs else None
    invalid = ~np.isfinite(data)
    if nodata is not None:
        invalid |= data == np.float32(nodata)
    data[invalid] = np.nan
    tags = _attribute(attrs, "tags", _parse_tags, path) if "tags" in attrs else {}
    crs_wkt = attrs.get("crsWkt", "")
    if not isinstance(crs_wkt, str):
        raise InputError(f"the header attribute {PREFIX}crsWkt of {path} is malformed: it is not text.")
    return Terrain(data, dx, dy, crs_wkt, transform, nodata, tags)


def _attribute(attrs: dict, name: str, parse, path: Path):
    """``parse(attrs[name])``, or an :class:`InputError` naming the attribute when the value is
    malformed (``parse`` raises ``ValueError`` or ``TypeError`` with what was expected)."""
    try:
        return parse(attrs[name])
    except (ValueError, TypeError) as exc:  # json.JSONDecodeError is a ValueError
        expected = exc.args[0] if isinstance(exc, _Malformed) else _EXPECTED[name]
        raise InputError(
            f"the header attribute {PREFIX}{name} of {path} is malformed ({expected}); "
            "rewrite the file with 'unerode convert' from its source raster or remove the attribute."
        ) from None


class _Malformed(ValueError):
    """A header value that parsed but is not what the attribute holds (the message says what)."""


_EXPECTED = {
    "transform": "expected a JSON list of 6 finite numbers",
    "cellSize": "expected two positive numbers in metres, e.g. '30 30'",
    "nodata": "expected a JSON number or null",
    "tags": "expected a JSON object",
}


def _parse_transform(value: str) -> list[float]:
    coefficients = json.loads(value)
    if (not isinstance(coefficients, list) or len(coefficients) != 6
            or not all(_is_number(c) and np.isfinite(c) for c in coefficients)):
        raise _Malformed(_EXPECTED["transform"])
    return [float(c) for c in coefficients]


def _parse_cell_size(value: str) -> tuple[float, float]:
    parts = value.split()
    if len(parts) != 2:
        raise _Malformed(_EXPECTED["cellSize"])
    dx, dy = (float(v) for v in parts)
    if not (np.isfinite(dx) and np.isfinite(dy) and dx > 0 and dy > 0):
        raise _Malformed(_EXPECTED["cellSize"])
    return dx, dy


def _parse_nodata(value: str) -> float | None:
    nodata = json.loads(value)
    if nodata is not None and not _is_number(nodata):
        raise _Malformed(_EXPECTED["nodata"])
    return nodata


def _parse_tags(value: str) -> dict:
    tags = json.loads(value)
    if not isinstance(tags, dict):
        raise _Malformed(_EXPECTED["tags"])
    return tags


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@contextlib.contextmanager
def _library_messages_silenced() -> Iterator[None]:
    """Send what the OpenEXR library and its bindings print themselves (file descriptors 1 and
    2: a warning, then one line per damaged chunk of a truncated file) to the null device while
    the block runs; the reading error itself is raised as an exception and said in one
    sentence."""
    saved: list[tuple[int, int]] = []
    try:
        for stream, fd in ((sys.stdout, 1), (sys.stderr, 2)):
            with contextlib.suppress(AttributeError, OSError, ValueError):
                stream.flush()
            saved.append((fd, os.dup(fd)))
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            for fd, _ in saved:
                os.dup2(null, fd)
        finally:
            os.close(null)
    except OSError:
        _restore(saved)
        yield
        return
    try:
        yield
    finally:
        _restore(saved)


def _restore(saved: list[tuple[int, int]]) -> None:
    for fd, copy in saved:
        os.dup2(copy, fd)
        os.close(copy)


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
