"""CF-1.8 NetCDF: the snapshots of a run as one time series, and the variable of a single
raster written as ``.nc`` named and given its units.

A snapshot series (:func:`write_series`) is one NetCDF-4 file with dimensions
``(time, y, x)`` (``lat``/``lon`` for a geographic CRS):

- ``time(time)``: the simulated time of each snapshot in ``year`` (UDUNITS), increasing: years
  after the start of the run for erode, unerode (negative: backward) and glaciate, years
  relative to the present (negative: before present) for runs along a chronology. It is
  not a CF calendar time (no ``since`` in its units): the ages of landscape evolution lie
  beyond what calendar dates can hold (xarray and cftime stop at about ±292,000 years), so
  ``xarray.open_dataset`` leaves it numeric and GDAL/QGIS show its values as band times.
  ``axis = "T"`` marks it as the time axis.
- ``age(time)``: where the snapshots have ages, the age before present (1950) in ``kyr``
  (thousands of years; UDUNITS' ``ka`` would be kilo-ares), an auxiliary coordinate named in
  the data variable's ``coordinates``.
- ``x(x)``, ``y(y)``: the cell centres in the CRS's units (``projection_x_coordinate``,
  ``projection_y_coordinate``); ``lon(lon)``, ``lat(lat)`` in degrees for a geographic CRS.
- ``crs``: the grid mapping, with the attributes of pyproj's ``CRS.to_cf()`` (``crs_wkt`` in
  WKT2 and the CF projection parameters), GDAL's ``spatial_ref`` and ``GeoTransform`` (so that
  GDAL and QGIS read the exact CRS and grid).
- the data variable (``elevation``: ``standard_name = surface_altitude``, ``units = m``; or
  ``ice_thickness``: ``land_ice_thickness``), float32, ``_FillValue`` for nodata, zlib level 4
  with shuffle, chunked one snapshot by at most 512 × 512 cells.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from importlib.metadata import version
from pathlib import Path

import netCDF4
import numpy as np
from affine import Affine
from pyproj import CRS

from unerode_cli.errors import InputError
from unerode_cli.io.netcdf_raster import ELEVATION, Quantity
from unerode_cli.io.paths import atomic_path, check_output
from unerode_cli.io.rasters import read_header, read_terrain

#: Fill value of the data variables unless the snapshots declare their own nodata value.
FILL = -9999.0
#: Largest chunk edge (cells) of a data variable.
CHUNK = 512
#: Tags of the snapshots giving the simulated time (years) and the age (ka).
TIME_TAG = "UNERODE_TIME_Y"
AGE_TAG = "UNERODE_AGE_KA"


def check_series(path: Path, snapshots: bool, hint: str, overwrite: bool, inputs: tuple[Path, ...]) -> None:
    """Refuse (InputError), before any work, a ``--snapshots-nc`` output that is not a ``.nc``
    file, that exists (without ``overwrite``) or is an input, or a run that writes no
    snapshot (``hint``: the option that asks for them, e.g. ``--snapshot-every``)."""
    if path.suffix.lower() != ".nc":
        raise InputError(f"--snapshots-nc writes a NetCDF file: {path.name} does not end in .nc.")
    if not snapshots:
        raise InputError(f"--snapshots-nc gathers the run's snapshots, and this run writes none; "
                         f"give {hint}.")
    check_output(path, overwrite, inputs)


def write_series(path: Path, snapshots: Sequence[Path], quantity: Quantity = ELEVATION,
                 title: str = "") -> None:
    """Write the rasters ``snapshots`` (one grid, each tagged with its time and optionally its
    age, see :data:`TIME_TAG`) as one CF-1.8 time series at ``path``, atomically, in time
    order; one snapshot is held in memory at a time. Refused (InputError): no snapshot, or
    snapshots on different grids."""
    write_variables(path, [(quantity, snapshots)], title or f"{quantity.long_name} snapshots")


def write_variables(path: Path, variables: Sequence[tuple[Quantity, Sequence[Path]]], title: str) -> None:
    """Write several data variables on one time axis: for each ``(quantity, snapshots)`` the
    rasters of one grid tagged with their times, as in :func:`write_series` (e.g. the
    members' mean, spread and percentiles of an ensemble's snapshots). The first variable's
    snapshots set the time axis; the others must have the same times. Refused (InputError): no
    snapshot, snapshots on different grids or at other times."""
    if not variables or not variables[0][1]:
        raise InputError(f"there are no snapshots to write into {path.name}.")
    reference = Path(variables[0][1][0])
    first = read_header(reference)
    orders = [_time_order(snapshots) for _, snapshots in variables]
    times = [t for t, _, _ in orders[0]]
    ages = [a for _, a, _ in orders[0]]
    if any([t for t, _, _ in order] != times for order in orders[1:]):
        raise InputError(f"the variables of {path.name} have snapshots at different times.")
    fill = FILL if first.nodata is None or not math.isfinite(first.nodata) else float(first.nodata)
    with atomic_path(path) as tmp, netCDF4.Dataset(tmp, "w", format="NETCDF4") as ds:
        _global_attributes(ds, title)
        xname, yname = _coordinates(ds, first.crs_wkt, first.transform, first.shape)
        _time_axis(ds, times, ages if all(a is not None for a in ages) else None)
        rows, cols = first.shape
        for (quantity, _), order in zip(variables, orders, strict=True):
            var = ds.createVariable(quantity.name, "f4", ("time", yname, xname), zlib=True, complevel=4,
                                    shuffle=True, chunksizes=(1, min(rows, CHUNK), min(cols, CHUNK)),
                                    fill_value=np.float32(fill))
            _describe(var, quantity, bool(first.crs_wkt), "age" in ds.variables)
            for k, (_, _, snapshot) in enumerate(order):
                layer = read_terrain(snapshot)
                if layer.shape != first.shape or not layer.transform.almost_equals(first.transform):
                    raise InputError(f"snapshot {snapshot} is not on the grid of {reference}.")
                var[k] = np.where(np.isfinite(layer.elevation), layer.elevation, fill).astype(np.float32)


def _time_order(snapshots: Sequence[Path]) -> list[tuple[float, float | None, Path]]:
    """(time in years, age in ka or None, path) of each snapshot, by increasing time."""
    found = []
    for k, snapshot in enumerate(snapshots):
        tags = read_header(Path(snapshot)).tags
        age = float(tags[AGE_TAG]) if AGE_TAG in tags else None
        if age is not None:
            time = -1000.0 * age
        elif TIME_TAG in tags:
            time = float(tags[TIME_TAG])
        else:
            time = float(k + 1)
        found.append((time, age, Path(snapshot)))
    return sorted(found, key=lambda item: item[0])


def _global_attributes(ds: netCDF4.Dataset, title: str) -> None:
    ds.Conventions = "CF-1.8"
    ds.title = title
    ds.source = f"unerode-cli {version('unerode-cli')}"


def _coordinates(ds: netCDF4.Dataset, crs_wkt: str, transform: Affine | None,
                 shape: tuple[int, int]) -> tuple[str, str]:
    """Create the x/y (or lon/lat) coordinate variables of the cell centres and the ``crs``
    grid mapping; returns the names of the x and y dimensions."""
    transform = transform or Affine.identity()
    rows, cols = shape
    xs = transform.c + (np.arange(cols) + 0.5) * transform.a
    ys = transform.f + (np.arange(rows) + 0.5) * transform.e
    crs = CRS.from_wkt(crs_wkt) if crs_wkt else None
    if crs is not None and crs.is_geographic:
        axes = (("lon", xs, "longitude", "degrees_east", "X"), ("lat", ys, "latitude", "degrees_north", "Y"))
    else:
        unit = _linear_unit(crs)
        axes = (("x", xs, "projection_x_coordinate", unit, "X"),
                ("y", ys, "projection_y_coordinate", unit, "Y"))
    for name, values, standard_name, units, axis in axes:
        ds.createDimension(name, len(values))
        var = ds.createVariable(name, "f8", (name,))
        var[:] = values
        var.standard_name, var.units, var.axis = standard_name, units, axis
        var.long_name = f"{standard_name.replace('_', ' ')} of cell centres"
    if crs is not None:
        mapping = ds.createVariable("crs", "i4")
        for key, value in crs.to_cf().items():
            mapping.setncattr(key, value)
        mapping.spatial_ref = crs_wkt
        mapping.GeoTransform = " ".join(repr(float(v)) for v in (transform.c, transform.a, transform.b,
                                                                 transform.f, transform.d, transform.e))
    return axes[0][0], axes[1][0]


def _linear_unit(crs: CRS | None) -> str:
    """The UDUNITS name of a projected CRS's axis unit ("m" without a CRS)."""
    if crs is None or not crs.axis_info:
        return "m"
    name = crs.axis_info[0].unit_name
    return {"metre": "m", "meter": "m", "foot": "ft", "US survey foot": "US_survey_foot"}.get(name, name)


def _time_axis(ds: netCDF4.Dataset, times: list[float], ages: list[float] | None) -> None:
    ds.createDimension("time", len(times))
    time = ds.createVariable("time", "f8", ("time",))
    time[:] = times
    time.units, time.axis = "year", "T"
    time.long_name = ("simulated time relative to the present (negative: before present)" if ages is not None
                      else "simulated time since the start of the run (negative: backward in time)")
    if ages is not None:
        age = ds.createVariable("age", "f8", ("time",))
        age[:] = ages
        age.units = "kyr"
        age.long_name = "age before present (1950), in thousands of years (ka)"


def _describe(var: netCDF4.Variable, quantity: Quantity, mapped: bool, aged: bool) -> None:
    if quantity.standard_name:
        var.standard_name = quantity.standard_name
    var.long_name, var.units = quantity.long_name, quantity.units
    if quantity.cell_methods:
        var.cell_methods = quantity.cell_methods
    if mapped:
        var.grid_mapping = "crs"
    if aged:
        var.coordinates = "age"
