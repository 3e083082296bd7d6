"""`unerode-cli flow DEM OUT`: discharge, drainage area or D8 receivers of a DEM."""

from __future__ import annotations

from enum import Enum
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import (
    Band,
    Channel,
    Cog,
    CreationOptions,
    Dirichlet,
    InputDem,
    Method,
    Outlets,
    OutputDem,
    Overwrite,
    Preview,
    Quiet,
    SeaLevel,
    Verbose,
)


class What(str, Enum):
    discharge = "discharge"
    area = "area"
    receivers = "receivers"


def flow(
    dem: InputDem,
    output: OutputDem,
    what: Annotated[What, typer.Option(help="discharge (m³/y), drainage area (m²), or receivers (ESRI D8 codes: E 1, SE 2, S 4, SW 8, W 16, NW 32, N 64, NE 128; 0 outlet).")] = What.discharge,
    method: Annotated[Method, typer.Option(help="mfd: multiple flow directions ∝ slope; d8: steepest descent.")] = Method.mfd,
    precipitation: Annotated[str, typer.Option("--precipitation", "-p", help="Precipitation rate (m/y): a number or a raster on the DEM's grid.")] = "1.0",
    outlets: Outlets = "all",
    sea_level: SeaLevel = None,
    dirichlet: Dirichlet = None,
    band: Band = None,
    channel: Channel = None,
    cog: Cog = False,
    co: CreationOptions = None,
    overwrite: Overwrite = False,
    preview: Preview = None,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Route water over a DEM (depressions are routed across, the DEM is not changed)."""
    with reported_errors(verbose - quiet):
        import numpy as np

        from unerode_cli.cli.common import load
        from unerode_cli.hydro import accumulate, route
        from unerode_cli.hydro.directions import esri_d8_codes
        from unerode_cli.pipeline.boundaries import boundaries_from_options
        from unerode_cli.pipeline.outputs import Outputs, field_preview, save
        from unerode_cli.pipeline.parameter_maps import resolve
        from unerode_cli.processes.parameters import ParamSpec

        dtype = "uint8" if what is What.receivers else "float32"
        outs = Outputs.from_cli(output, dtype, cog, co, overwrite, preview)
        outs.check(dem)
        terrain = load(dem, band, channel)
        bounds = boundaries_from_options(terrain, outlets, sea_level, dirichlet)
        rain = resolve(ParamSpec("precipitation", "m/y", 1.0, "precipitation", 0.0, raster=True),
                       precipitation, terrain)
        routing = route(terrain.elevation, terrain.grid, bounds.outlets(terrain.elevation, terrain),
                        method.value)
        if what is What.receivers:
            values, unit, nodata = esri_d8_codes(routing.receivers(), terrain.shape).astype(float), "D8 code", 255.0
        else:
            source = rain if what is What.discharge else 1.0
            values = accumulate(routing, source)
            unit, nodata = ("m3/y" if what is What.discharge else "m2"), -9999.0
        values = np.where(terrain.nodata_mask, np.nan, values)
        layer = terrain.with_elevation(values)
        layer.nodata, layer.tags["UNIT"] = nodata, unit
        stats = {"outlet_cells": int(routing.outlets.sum()),
                 "max": float(np.nanmax(values)), "unit": unit}
        save(layer, outs, "flow",
                   {"input": dem, "what": what.value, "method": method.value,
                    "precipitation": precipitation, "outlets": outlets, "sea_level": sea_level,
                    "dirichlet": dirichlet}, stats, elevation_preview=False)
        if preview is not None:
            field_preview(values, terrain, preview, f"{what.value} ({unit})",
                          log=what is not What.receivers, title=output.name)
