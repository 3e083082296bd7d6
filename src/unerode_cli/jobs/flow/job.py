"""The `flow` job: discharge (m³/y), drainage area (m²) or D8 receivers of a DEM, routed across
depressions on the job's own copy of the DEM (the file is not changed), written with a sidecar and preview."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.hydro import accumulate, route
from unerode_cli.hydro.directions import esri_d8_codes
from unerode_cli.hydro.routing import release_scratch
from unerode_cli.io.paths import OutputPlan
from unerode_cli.io.rasters import is_exr, read_header, read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.flow.options import OPTIONS
from unerode_cli.processes.parameters import ParamSpec
from unerode_cli.run.boundaries import Boundaries, boundaries_from_options
from unerode_cli.run.common_options import input_georef
from unerode_cli.run.declare import declared
from unerode_cli.run.job import Job, Progress
from unerode_cli.run.memory import check_command
from unerode_cli.run.outputs import Outputs, field_preview, save
from unerode_cli.run.parameter_maps import resolve

PRECIPITATION = ParamSpec("precipitation", "m/y", 1.0, "precipitation", 0.0, raster=True)
#: Unit and nodata value written for each field.
FIELDS = {"discharge": ("m3/y", -9999.0), "area": ("m2", -9999.0), "receivers": ("D8 code", 255.0)}


def output_dtype(what: str) -> str:
    """uint8 for D8 codes, float32 for discharge and area."""
    return "uint8" if what == "receivers" else "float32"


@dataclass
class PlannedFlow:
    """The DEM read, its outlets, the precipitation (m/y, a number or a map) and the cleared
    outputs."""

    terrain: Terrain
    bounds: Boundaries
    rain: float | np.ndarray
    outputs: Outputs


@dataclass
class FlowField:
    """The field (discharge m³/y, area m² or D8 codes; NaN on nodata) and the number of outlet
    cells of the routing."""

    values: np.ndarray
    outlet_cells: int


@declared("flow", OPTIONS)
class FlowJob(Job):
    """Route water over a DEM: ``what`` is discharge, area or receivers; ``method`` mfd or d8;
    ``precipitation`` (m/y) a number or a raster path."""

    def plan(self, outputs: OutputPlan) -> PlannedFlow:
        """Check the outputs (D8 codes are uint8, which EXR cannot hold), read the DEM, its
        boundaries and the precipitation."""
        written = Outputs.from_cli(self.output, output_dtype(self.what), self.cog, self.co, self.overwrite,
                                   self.preview)
        if self.what == "receivers" and is_exr(self.output):
            raise InputError("EXR files hold float samples only, not the uint8 D8 codes of --what "
                             f"receivers: write {self.output.stem}.tif instead.")
        for path in (self.dem, self.dirichlet, _raster_path(self.precipitation)):
            if path is not None:
                outputs.read(path)
        written.check(self.dem)
        check_command("flow", read_header(self.dem, band=self.band, georef=input_georef(self)))
        terrain = read_terrain(self.dem, band=self.band, channel=self.channel, georef=input_georef(self))
        terrain.check_valid(self.dem)
        written.check_source(terrain, self.dem)
        bounds = boundaries_from_options(terrain, self.outlets, self.sea_level, self.dirichlet)
        rain = resolve(PRECIPITATION, self.precipitation, terrain)
        if self.what == "discharge":
            _check_discharge_fits(rain, terrain, self.precipitation)
        return PlannedFlow(terrain, bounds, rain, written)

    def run(self, planned: PlannedFlow, progress: Progress) -> tuple[PlannedFlow, FlowField]:
        """Route (across depressions) and accumulate, or encode the receivers as D8 codes.

        The DEM read is this job's own: the routing surface is filled into it (it keeps its
        nodata cells, +inf), and the routing's work arrays are dropped before accumulating."""
        terrain = planned.terrain
        grid = terrain.grid
        outlets = planned.bounds.outlets(terrain.elevation, terrain)
        routing = route(terrain.elevation, grid, outlets, self.method, filled=terrain.elevation)
        del outlets
        release_scratch()
        if self.what == "receivers":
            values = esri_d8_codes(routing.receivers(), terrain.shape).astype(float)
        else:
            values = accumulate(routing, planned.rain if self.what == "discharge" else 1.0)
        nodata = ~grid.valid
        values[nodata] = np.nan
        terrain.elevation[nodata] = np.nan   # the routing surface's +inf, for the preview
        return planned, FlowField(values, int(routing.outlets.sum()))

    def write(self, result: tuple[PlannedFlow, FlowField], outputs: OutputPlan) -> str:
        """Write the field with its unit and nodata value, its sidecar and its preview."""
        planned, field = result
        unit, nodata = FIELDS[self.what]
        layer = planned.terrain.holding(field.values)
        layer.nodata, layer.tags["UNIT"] = nodata, unit
        stats = {"outlet_cells": field.outlet_cells, "max": float(np.nanmax(field.values)), "unit": unit}
        save(layer, planned.outputs, self.COMMAND, self.provenance(), stats, elevation_preview=False)
        if self.preview is not None:
            field_preview(field.values, planned.terrain, self.preview, f"{self.what} ({unit})",
                          log=self.what != "receivers", title=self.output.name)
        return ""


def _check_discharge_fits(rain: float | np.ndarray, terrain: Terrain, given: str) -> None:
    """Refuse a precipitation (m/y) whose discharge could exceed what the float32 output holds:
    no discharge is above the precipitation summed over the DEM's domain times a cell's area
    (m³/y)."""
    valid = terrain.grid.valid
    with np.errstate(over="ignore", invalid="ignore"):
        if np.ndim(rain) == 0:
            total = float(rain) * float(np.count_nonzero(valid)) * terrain.grid.cell_area
        else:
            total = float(np.sum(rain, where=valid, dtype=np.float64)) * terrain.grid.cell_area
    if not total <= float(np.finfo(np.float32).max):
        raise InputError(f"--precipitation {given} m/y over the DEM could give discharges above "
                         f"{np.finfo(np.float32).max:.3g} m³/y, more than a float32 raster holds; give a "
                         "smaller precipitation.")


def _raster_path(value: str) -> Path | None:
    """The raster that a number-or-raster option names, None for a number."""
    try:
        float(value)
    except ValueError:
        return Path(value)
    return None
