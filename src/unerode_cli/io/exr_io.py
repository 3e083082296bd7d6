"""OpenEXR heightfields: one float32 channel ``Y`` in metres, georeferencing in the header.

Header attributes (strings, so that doubles survive exactly):

- ``crs``: the coordinate reference system as OGC WKT2 (ISO 19162:2019, as pyproj's
  ``CRS.to_wkt()`` writes it); absent when the heightfield has no CRS;
- ``unerode.transform``: JSON list of the 6 affine coefficients a, b, c, d, e, f (pixel →
  CRS coordinates of the cells' corners, GDAL's geotransform reordered as rasterio's
  ``Affine``);
- ``unerode.cellSize``: "dx dy", the cell size in metres;
- ``unerode.nodata``: JSON number or null;
- ``unerode.tags``: JSON object of kept tags.

Files written before the ``crs`` attribute hold their CRS as WKT (1 or 2) in
``unerode.crsWkt``, which is still read. A file without a transform is read with 1 m cells
unless ``--cell-size`` (and ``--crs``) assign its grid
(:class:`~unerode_cli.io.input_georef.InputGeoref`). A GeoTIFF → EXR → GeoTIFF trip is
lossless for float32 data.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import OpenEXR
from affine import Affine
from pyproj import CRS
from pyproj.exceptions import CRSError

from unerode_cli.errors import InputError
from unerode_cli.io.cellsize import cell_size_metres, check_north_up
from unerode_cli.io.gdal_io import output_nodata
from unerode_cli.io.input_georef import InputGeoref
from unerode_cli.io.terrain import Terrain

PREFIX = "unerode."
#: The header attribute holding the CRS as WKT2 (2019).
CRS_ATTRIBUTE = "crs"
#: Where files written before :data:`CRS_ATTRIBUTE` hold their CRS (WKT 1 or 2).
OLD_CRS_ATTRIBUTE = PREFIX + "crsWkt"
FLOAT_TYPES = (np.float16, np.float32)


@dataclass(frozen=True)
class ExrGeoref:
    """The georeferencing of an EXR heightfield: CRS (WKT, "" without), transform, cell size
    (m) and nodata value."""

    crs_wkt: str
    transform: Affine
    dx: float
    dy: float
    nodata: float | None


def read_exr(path: Path, channel: str | None = None, georef: InputGeoref | None = None) -> Terrain:
    """Read a heightfield channel: ``channel`` if given, else Y, else R, else the only float one,
    with the CRS, grid and nodata value ``georef`` assigns.

    Channels are read one by one (an RGB image gives R, G and B, never one grouped "RGB").
    """
    georef = georef or InputGeoref()
    try:
        with _library_messages_silenced(), OpenEXR.File(str(path), separate_channels=True) as exr:
            # The header mapping is only valid while the file is open: copy what is needed.
            attrs = _attributes(exr.header())
            channels = {name: ch.pixels for name, ch in exr.channels().items()}
    except Exception as exc:  # the bindings raise bare RuntimeError/OSError subclasses
        detail = str(exc).strip().splitlines()[0].rstrip(".") if str(exc).strip() else "unreadable"
        raise InputError(f"{path} is not an OpenEXR file that can be read, or it is damaged "
                         f"({detail}).") from None
    data = _pick_channel(channels, channel, path).astype(np.float64)
    where = exr_georef(attrs, data.shape, path, georef, note=True)
    invalid = ~np.isfinite(data)
    if where.nodata is not None:
        invalid |= data == np.float32(where.nodata)
    data[invalid] = np.nan
    georef.mask_nodata(data)
    tags = _attribute(attrs, "tags", _parse_tags, path) if "tags" in attrs else {}
    return Terrain(data, where.dx, where.dy, where.crs_wkt, where.transform, where.nodata, tags)


def _attributes(header: dict) -> dict:
    """The georeferencing attributes of an EXR header, keyed without the ``unerode.`` prefix
    (the WKT2 ``crs`` attribute under ``crs``, the old ``unerode.crsWkt`` under ``crsWkt``)."""
    attrs = {k[len(PREFIX):]: v for k, v in header.items() if k.startswith(PREFIX)}
    if CRS_ATTRIBUTE in header:
        attrs[CRS_ATTRIBUTE] = header[CRS_ATTRIBUTE]
    return attrs


def read_exr_georef(path: Path, header: dict, shape: tuple[int, int], georef: InputGeoref) -> ExrGeoref:
    """The georeferencing of an EXR from its ``header`` (read with ``header_only``), as
    :func:`read_exr` gives it (no note said)."""
    return exr_georef(_attributes(header), shape, path, georef, note=False)


def exr_georef(attrs: dict, shape: tuple[int, int], path: Path, georef: InputGeoref,
               note: bool) -> ExrGeoref:
    """The CRS, transform, cell size (m) and nodata value of an EXR of ``shape`` from its
    attributes (:func:`_attributes`) and what ``georef`` assigns; without a transform (and
    ``--cell-size``), 1 m cells whose lower-left corner is at (0, 0), said on stderr when
    ``note``."""
    file_wkt = _crs_text(attrs, path)
    crs_wkt = georef.resolve_crs(file_wkt, path)
    file_transform = Affine(*_attribute(attrs, "transform", _parse_transform, path)) \
        if "transform" in attrs else None
    transform = georef.resolve_transform(file_transform, shape, path)
    nodata = _attribute(attrs, "nodata", _parse_nodata, path) if "nodata" in attrs else None
    nodata = nodata if georef.nodata is None else georef.nodata
    if transform is None:
        if note:
            print(f"note: {path} carries no georeferencing; cells are taken to be 1 m (assign them with "
                  "--cell-size and --crs).", file=sys.stderr)
        return ExrGeoref(crs_wkt, Affine(1.0, 0.0, 0.0, 0.0, -1.0, float(shape[0])), 1.0, 1.0, nodata)
    check_north_up(transform, str(path))
    if file_transform is not None and "cellSize" in attrs and crs_wkt == file_wkt:
        dx, dy = _attribute(attrs, "cellSize", _parse_cell_size, path)
    elif crs_wkt:
        size = cell_size_metres(crs_wkt, transform, shape, str(path))
        dx, dy = size.dx, size.dy
    else:
        dx, dy = abs(transform.a), abs(transform.e)
    return ExrGeoref(crs_wkt, transform, dx, dy, nodata)


def _crs_text(attrs: dict, path: Path) -> str:
    """The file's CRS as WKT2 from ``crs``, else from the old ``unerode.crsWkt``; "" without;
    InputError naming the attribute when it is not a CRS pyproj reads."""
    name = CRS_ATTRIBUTE if CRS_ATTRIBUTE in attrs else "crsWkt"
    text = attrs.get(name, "")
    shown = CRS_ATTRIBUTE if name == CRS_ATTRIBUTE else OLD_CRS_ATTRIBUTE
    if not isinstance(text, str):
        raise InputError(f"the header attribute {shown} of {path} is malformed: it is not text.")
    if not text:
        return ""
    try:
        return CRS.from_user_input(text).to_wkt()
    except CRSError:
        raise InputError(f"the header attribute {shown} of {path} is malformed (not a CRS that pyproj "
                         "reads); rewrite the file with 'unerode convert' from its source raster or remove "
                         "the attribute.") from None


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
        **({CRS_ATTRIBUTE: CRS.from_user_input(terrain.crs_wkt).to_wkt()} if terrain.crs_wkt else {}),
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
