"""Options of `climate-run` (declared once: CLI, pipeline, Python API, provenance)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from unerode_cli.glacier.coupled import ICEFLOWS
from unerode_cli.run.common_options import (
    BOUNDARY_PANEL,
    CHECKPOINTS,
    COAST,
    DIRICHLET,
    EDGE_BASE,
    FORCE,
    GEOREF,
    METRES,
    OUTLETS,
    OUTPUT,
    OUTPUT_PANEL,
    POSITIVE_YEARS,
    RASTER_OUTPUT,
    SNAPSHOTS_NC,
    SOURCE,
)
from unerode_cli.run.declare import Opt, parameter_options
from unerode_cli.run.glacial.options import PARAMETER_PANELS as GLACIER_PANELS
from unerode_cli.run.process_options import INFLOW, PARAMETER_PANELS
from unerode_cli.run.values import Number, Numbers

AGE = Number("ka")
CHRONOLOGY_PANEL = "Chronology and sea level"
RUN_PANEL = "Time steps"
GLACIER_PANEL = "Glaciers (--process glacial)"
#: The processes' parameters, then the glacier model's (a parameter both offer keeps its first
#: panel, so that the glacier panels hold the glacier model's own).
PANELS = {**PARAMETER_PANELS,
          **{f"{title}, with --process glacial": specs for title, specs in GLACIER_PANELS.items()}}
PROCESS_HELP = ("Processes applied in this order within each step: fluvial, thermal, thermal-ca, hillslope, "
                "debris; or glacial (forward only: glaciate's glacier model, 001 §3–6, its ELA from the "
                "chronology) with any of hillslope, debris, fluvial for the ground without ice, "
                "whose base level follows sea level.")

OPTIONS = (
    SOURCE,
    OUTPUT,
    Opt("chronology", Path, None, "Chronology table: an LR04-style δ18O stack (age ka, δ18O ‰), or a "
        "sea-level curve with --chronology-kind sea-level.", required=True, role="input",
        panel=CHRONOLOGY_PANEL),
    Opt("from_ka", float, 0.0, "Age of the input DEM (ka; 0 = present).", flags=("--from",), parser=AGE,
        panel=CHRONOLOGY_PANEL),
    Opt("to_ka", float, 20.0, "Age to reach (ka): older than --from runs backward (unerosion), younger runs "
        "forward.", flags=("--to",), parser=AGE, panel=CHRONOLOGY_PANEL),
    Opt("direction", str, None, "Checked against --from/--to (optional).", choices=("backward", "forward"),
        panel=CHRONOLOGY_PANEL),
    Opt("chronology_kind", str, "d18o", "What --chronology holds.", choices=("d18o", "sea-level"),
        panel=CHRONOLOGY_PANEL),
    Opt("sea_level_file", Path, None, "Sea-level table (age ka, m relative to present); default: sea level "
        "from δ18O by a linear mapping.", flags=("--sea-level",), role="input", panel=CHRONOLOGY_PANEL),
    Opt("d18o_mapping", str, None, "SLOPE,INTERCEPT of sea (m) = INTERCEPT + SLOPE × δ18O (‰) (default: "
        "fitted on LR04 vs Spratt & Lisiecki 2016).", flags=("--d18o-to-sea",),
        parser=Numbers("SLOPE,INTERCEPT: two numbers separated by a comma", 2), metavar="SLOPE,INTERCEPT",
        panel=CHRONOLOGY_PANEL),
    Opt("sea_level_extend", str, "none", "Beyond the oldest age of --sea-level: none (a run older than the "
        "table is refused) or d18o (continue it with sea level from the δ18O --chronology, by the "
        "least-squares line of the table against δ18O over their overlap, the join residual tapered to "
        "0 over 10 ka).", choices=("none", "d18o"), panel=CHRONOLOGY_PANEL),
    Opt("dt", float, 1000.0, "Time step (years, > 0).", parser=POSITIVE_YEARS, panel=RUN_PANEL),
    Opt("process", str, "fluvial,thermal", PROCESS_HELP, panel=RUN_PANEL),
    Opt("snapshots_ka", str, None, "Ages (ka, comma-separated) at which to write OUTPUT_<age>ka snapshots.",
        flags=("--snapshots",), parser=Numbers("ages in ka separated by commas"), metavar="AGES",
        panel=OUTPUT_PANEL),
    SNAPSHOTS_NC,
    Opt("schedule_file", Path, None, "YAML schedule: per-phase parameter values (glacial, end-of-glacial, "
        "interglacial) and the downstream K_d range.", flags=("--params",), role="input",
        panel=CHRONOLOGY_PANEL),
    Opt("downstream_below", float, None, "Downstream region (K_d follows sea level, 000 §5.2): cells below "
        "this elevation (m) of the input.", parser=METRES, panel=BOUNDARY_PANEL),
    Opt("downstream_mask", Path, None, "Downstream region as a raster on the DEM's grid (non-zero cells).",
        role="input", panel=BOUNDARY_PANEL),
    Opt("uplift_map", Path, None, "Uplift raster (m/y) on the DEM's grid, multiplied through time by the "
        "factor of --uplift TABLE.csv (columns age_ka,factor); --uplift also takes a table age_ka,U_m_per_y, "
        "linear in age, covering the run.", role="input", panel=CHRONOLOGY_PANEL),
    dataclasses.replace(OUTLETS, default=None, help=f"{OUTLETS.help} Default: all; in a nested run "
                        "(--inflow-from), the boundary cells where the coarse run's water leaves this map."),
    DIRICHLET,
    INFLOW,
    FORCE,
    *GEOREF,
    Opt("sea_outlets", bool, True, "Cells at or below the current sea level are outlets, and boundary nodes "
        "at or below the sea level of --from follow sea level.", kind="flag", off_flag="--no-sea-outlets",
        panel=BOUNDARY_PANEL),
    COAST,
    EDGE_BASE,
    Opt("inflow_from", Path, None, "A coarse climate-run over a larger area, run with --write-fluxes (its "
        "output raster or its OUT_fluxes folder): the water and sediment crossing into this map, and the "
        "level of its edges, are read off it at each step (000 §6.3.1).", role="input", panel=BOUNDARY_PANEL),
    Opt("write_fluxes", bool, False, "Also write OUT_fluxes/: elevation, discharge and sediment flux rasters "
        "(m, m³/y) at --from, each snapshot and --to, for runs nested in this one (--inflow-from).",
        kind="flag", panel=OUTPUT_PANEL),
    *CHECKPOINTS,
    Opt("no_substep", bool, False, "Refuse an unstable --dt instead of sub-stepping it.", kind="flag",
        panel=RUN_PANEL),
    Opt("scheme", str, "limiter", "Slope of backward steps: limiter (000 Eq. 12) or upwind (Eq. 10).",
        choices=("limiter", "upwind"), panel=RUN_PANEL),
    Opt("method", str, "mfd", "Flow routing: mfd or d8.", choices=("mfd", "d8"), panel=RUN_PANEL),
    Opt("thermal_constraints", str, "slope,convexity,rate", "Un-deposition constraints of thermal "
        "unerosion: slope, convexity, rate, or none.", panel=RUN_PANEL, record="constraints"),
    Opt("ela_present", float, None, "With --process glacial: today's ELA (m), the ELA at 0 ka; the ELA is "
        "linear in the chronology between it and --ela-glacial.", parser=Number("m"), panel=GLACIER_PANEL),
    Opt("ela_glacial", float, None, "With --process glacial: the ELA at the last glacial maximum (m), where "
        "the chronology is most glacial between 14 and 30 ka.", parser=Number("m"), panel=GLACIER_PANEL),
    Opt("iceflow", str, None, "With --process glacial: the glaciers' ice flow, blatter (default: the "
        "Blatter–Pattyn energy, 001 Eq. 7), sia (shallow ice, fast baseline) or cnn (001 §4: a network "
        "trained on the fly predicts the velocities, the converged solver finishes them; needs "
        "PyTorch; see glaciate).", choices=ICEFLOWS, panel=GLACIER_PANEL),
    Opt("seed", int, None, "With --process glacial and --iceflow cnn: seed of the network's initial "
        "weights (default 0; the same seed gives the same run, bit for bit, on the same CPU and "
        "threads).", minimum=0, panel=GLACIER_PANEL),
    *RASTER_OUTPUT,
    Opt("report", bool, False, "Also write OUTPUT_report.html when the run finishes: previews at each "
        "snapshot, chronology and timeline plots, mass budget, parameters and history (see unerode-cli "
        "report).", kind="flag", panel=OUTPUT_PANEL, record=False),
) + parameter_options(PANELS)
