"""Declarations that the jobs running the runner's processes share (erode, unerode, climate-run):
the help panels of the processes' parameters and the rivers entering the map."""

from __future__ import annotations

from pathlib import Path

from unerode_cli.processes import debris, fluvial, hillslope, thermal
from unerode_cli.run.common_options import BOUNDARY_PANEL
from unerode_cli.run.declare import Opt

#: The processes' parameters by help panel (``run.declare.parameter_options``).
PARAMETER_PANELS = {
    "Fluvial parameters (000 §3)": fluvial.PARAMETERS,
    "Thermal parameters (000 §4; thermal and thermal-ca)": thermal.PARAMETERS,
    "Hillslope parameters (001 §6.4)": hillslope.PARAMETERS,
    "Debris-flow parameters (001 Eq. 8)": debris.PARAMETERS,
}

INFLOW = Opt("inflow", Path, None, "CSV of rivers entering the map, columns x,y,discharge_m3_per_y,"
             "sediment_m3_per_y (DEM's CRS; m³/y): each point is snapped to the nearest valid cell, "
             "within one cell of the edge or of nodata and not an outlet, where its water joins the "
             "discharge and its sediment the fluvial sediment flux. climate-run also takes an age_ka "
             "column: each river's rows at several ages, linear in age.", role="input",
             panel=BOUNDARY_PANEL)
