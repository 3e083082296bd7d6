"""The variable of a single raster that GDAL writes as NetCDF (``Band1``) named, with its
units and long name (CF-1.8), and the quantities of NetCDF data variables."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import netCDF4


@dataclass(frozen=True)
class Quantity:
    """What a data variable holds: its NetCDF name, CF standard name ("" when none), long name
    and UDUNITS units."""

    name: str
    standard_name: str
    long_name: str
    units: str
    #: CF ``cell_methods`` ("realization: mean" for an ensemble mean), "" when none.
    cell_methods: str = ""


ELEVATION = Quantity("elevation", "surface_altitude", "surface elevation", "m")
ICE_THICKNESS = Quantity("ice_thickness", "land_ice_thickness", "ice thickness", "m")


def name_raster_variable(path: Path, tags: dict[str, str]) -> None:
    """Give the variable GDAL writes as ``Band1`` in a single-raster NetCDF its name, units and
    long name (in place): ``elevation`` (``surface_altitude``, m) unless the raster's tags say
    another quantity (``UNERODE_QUANTITY``) or unit (``UNIT``), then ``value`` with that unit."""
    unit = tags.get("UNIT", "")
    quantity = ELEVATION
    if "UNERODE_QUANTITY" in tags or unit not in ("", "m", "metre", "meter", "metres"):
        text = tags.get("UNERODE_QUANTITY", "value")
        quantity = Quantity(_identifier(text), "", text, unit or "1")
    with netCDF4.Dataset(path, "a") as ds:
        if "Band1" not in ds.variables:
            return
        ds.renameVariable("Band1", quantity.name)
        var = ds.variables[quantity.name]
        for key in ("standard_name", "long_name", "units"):
            if key in var.ncattrs():
                var.delncattr(key)
        if quantity.standard_name:
            var.standard_name = quantity.standard_name
        var.long_name, var.units = quantity.long_name, quantity.units
        ds.Conventions = "CF-1.8"


def _identifier(text: str) -> str:
    name = "".join(c if c.isalnum() else "_" for c in text.strip().lower()).strip("_")
    return name if name and not name[0].isdigit() else f"v_{name}"
