"""A `flow` job: discharge (m³/y), drainage area (m²) or D8 receivers of a DEM, routed across
depressions on a routing copy (the DEM is not changed), written with a sidecar and preview."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.hydro import accumulate, route
from unerode_cli.hydro.directions import esri_d8_codes
from unerode_cli.io.rasters import is_exr, read_terrain
from unerode_cli.processes.parameters import ParamSpec
from unerode_cli.run.boundaries import boundaries_from_options
from unerode_cli.run.outputs import Outputs, field_preview, save
from unerode_cli.run.parameter_maps import resolve

PRECIPITATION = ParamSpec("precipitation", "m/y", 1.0, "precipitation", 0.0, raster=True)
#: Unit and nodata value written for each field.
FIELDS = {"discharge": ("m3/y", -9999.0), "area": ("m2", -9999.0), "receivers": ("D8 code", 255.0)}


@dataclass(frozen=True)
class FlowJob:
    """What the user asked for: ``what`` is discharge, area or receivers; ``method`` mfd or d8;
    ``precipitation`` (m/y) a number or a raster path."""

    source: Path
    outputs: Outputs
    what: str = "discharge"
    method: str = "mfd"
    precipitation: str = "1.0"
    outlets: str = "all"
    sea_level: float | None = None
    dirichlet: Path | None = None
    band: int | None = None
    channel: str | None = None


def output_dtype(what: str) -> str:
    """uint8 for D8 codes, float32 for discharge and area."""
    return "uint8" if what == "receivers" else "float32"


def run_flow(job: FlowJob) -> None:
    """Check the outputs, read the DEM, route, accumulate and write field, sidecar and preview."""
    outputs = job.outputs
    if job.what == "receivers" and is_exr(outputs.path):
        raise InputError("EXR files hold float samples only, not the uint8 D8 codes of --what "
                         f"receivers: write {outputs.path.stem}.tif instead.")
    outputs.check(job.source)
    terrain = read_terrain(job.source, band=job.band, channel=job.channel)
    terrain.check_valid(job.source)
    outputs.check_source(terrain, job.source)
    bounds = boundaries_from_options(terrain, job.outlets, job.sea_level, job.dirichlet)
    rain = resolve(PRECIPITATION, job.precipitation, terrain)
    routing = route(terrain.elevation, terrain.grid, bounds.outlets(terrain.elevation, terrain), job.method)
    if job.what == "receivers":
        values = esri_d8_codes(routing.receivers(), terrain.shape).astype(float)
    else:
        values = accumulate(routing, rain if job.what == "discharge" else 1.0)
    unit, nodata = FIELDS[job.what]
    values = np.where(terrain.nodata_mask, np.nan, values)
    layer = terrain.with_elevation(values)
    layer.nodata, layer.tags["UNIT"] = nodata, unit
    stats = {"outlet_cells": int(routing.outlets.sum()), "max": float(np.nanmax(values)), "unit": unit}
    save(layer, outputs, "flow",
         {"input": job.source, "what": job.what, "method": job.method, "precipitation": job.precipitation,
          "outlets": job.outlets, "sea_level": job.sea_level, "dirichlet": job.dirichlet},
         stats, elevation_preview=False)
    if outputs.preview is not None:
        field_preview(values, terrain, outputs.preview, f"{job.what} ({unit})",
                      log=job.what != "receivers", title=outputs.path.name)

