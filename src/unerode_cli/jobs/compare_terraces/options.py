"""Options of `compare-terraces` (declared once: CLI, pipeline, Python API)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from unerode_cli.run.common_options import GEOREF, OUTLETS, OVERWRITE, SEA_LEVEL
from unerode_cli.run.declare import Opt
from unerode_cli.run.values import Number

#: Exit code when the terrace RMSE exceeds --fail-above (a gate for Makefiles).
EXIT_ABOVE_THRESHOLD = 3

INPUTS, RIVER, COMPARISON = "Inputs", "River", "Comparison"

OPTIONS = (
    Opt("present", Path, help="Today's DEM, the reference of the heights.", required=True, role="input",
        panel=INPUTS),
    Opt("snapshots", str, help="Snapshot raster, folder of snapshots, or quoted glob ('runs/past_*ka.tif'); "
        "repeatable. Ages come from climate-run's UNERODE_AGE_KA tag, else a name ending in _<age>ka.",
        kind="multiple", required=True, panel=INPUTS),
    Opt("out", Path, help="Write the report in this folder: terraces.csv, profiles.csv, summary.json, "
        "profiles.png (+ incision.csv, incision.png).", required=True, role="output", panel=INPUTS),
    Opt("observations", Path, None, "CSV of dated terraces with the columns age_ka and height_above_river_m, "
        "and optionally uncertainty_m, x and y (DEM's CRS) or chainage_m, and name.", role="input",
        panel=INPUTS),
    Opt("incision", Path, None, "CSV of incision rates with the columns from_ka, to_ka and rate_mm_per_ka, "
        "and optionally uncertainty_mm_per_ka and name.", role="input", panel=INPUTS),
    # in a panel of their own: beside the required options of Inputs their names would be cut
    *(dataclasses.replace(opt, panel="Georeferencing of the inputs") for opt in GEOREF),
    Opt("river", Path, None, "River line in the DEM's CRS: GeoJSON or WKT LINESTRING (either direction).",
        role="input", panel=RIVER),
    Opt("auto_river", bool, False, "Extract the main channel by steepest descent instead of --river.",
        kind="flag", panel=RIVER),
    Opt("river_start", str, None, "X,Y (DEM's CRS) where the automatic river starts; default: up the main "
        "stem of the largest catchment.", panel=RIVER),
    Opt("min_area_fraction", float, 0.01, "The automatic main stem ends where its tributaries drain less "
        "than this share of the catchment.", parser=Number(minimum=0.0, maximum=1.0, above=True),
        panel=RIVER),
    Opt("search_radius", float, 0.0, "Riverbed = lowest cell within this distance (m) of the river line; "
        "0: the cell under it.", parser=Number("m", 0.0), panel=RIVER),
    OUTLETS,
    SEA_LEVEL,
    Opt("uplift", float, 0.0, "Rock uplift rate since each age (m/y): a terrace formed at age a now stands "
        "U·a higher than its simulated bed.", parser=Number("m/y"), panel=COMPARISON),
    Opt("fail_above", float, None, f"Exit with code {EXIT_ABOVE_THRESHOLD} when the terrace RMSE exceeds "
        "this (m), after writing the report.", parser=Number("m", 0.0), panel=COMPARISON),
    OVERWRITE,
)
