"""Options of `erode` and `unerode` (declared once: CLI, pipeline, Python API, provenance)."""

from __future__ import annotations

from pathlib import Path

from unerode_cli.processes import thermal
from unerode_cli.run.common_options import (
    CHECKPOINTS,
    DIRICHLET,
    FORCE,
    OUTLETS,
    OUTPUT,
    POSITIVE_YEARS,
    RASTER_OUTPUT,
    READING,
    SEA_LEVEL,
    SNAPSHOTS_NC,
    SOURCE,
)
from unerode_cli.run.declare import Opt, parameter_options
from unerode_cli.run.process_options import INFLOW, PARAMETER_PANELS

#: --scheme's choices: the forward fluvial schemes of erode, the backward slopes of unerode
FORWARD_SCHEMES = ("auto", "implicit", "explicit")
BACKWARD_SCHEMES = ("limiter", "upwind")
SCHEMES = FORWARD_SCHEMES + BACKWARD_SCHEMES

PROCESS_HELP = ("Process(es), comma-separated, applied in this order within each step (operator "
                "splitting): fluvial, thermal, thermal-ca (forward only), hillslope (forward only), "
                "debris (forward only).")

METHOD = Opt("method", str, "mfd", "Flow routing: mfd (multiple flow directions) or d8.",
             choices=("mfd", "d8"))
PARAMS_FILE = Opt("params", Path, None, "YAML file of parameter values (name or symbol → number or raster "
                  "path, optionally grouped under process names); command-line values win.", role="input",
                  record="params_file")

OPTIONS = (
    SOURCE,
    OUTPUT,
    Opt("process", str, "fluvial", PROCESS_HELP),
    PARAMS_FILE,
    Opt("dt", float, 1000.0, "Time step (years, > 0; unerode runs it backward).", parser=POSITIVE_YEARS),
    Opt("duration", float, None, "Simulated time (years); or give --steps.", parser=POSITIVE_YEARS),
    Opt("steps", int, None, "Number of time steps; or give --duration.", minimum=1),
    Opt("no_substep", bool, False, "Refuse an unstable --dt instead of sub-stepping it.", kind="flag"),
    Opt("snapshot_every", float, None, "Write a numbered snapshot OUTPUT_k every this many simulated years.",
        parser=POSITIVE_YEARS, record=False),
    SNAPSHOTS_NC,
    Opt("change_map", Path, None, "Write the signed change (m) due to the processes (uplift excluded): "
        "< 0 erosion, > 0 deposition.", role="output", record=False),
    Opt("scheme", str, None, "Fluvial scheme. erode: implicit (Braun & Willett 2013 with Yuan et al. "
        "2019's deposition, stable at any --dt), explicit (000 Eq. 9, sub-stepped to its CFL bound), or auto "
        "(default: implicit where the explicit scheme would need more than 4 sub-steps a step, 2 without "
        "deposition, decided on the first step). unerode: the slope of backward fluvial and thermal steps, "
        "limiter (default; 000 Eq. 12) or upwind (Eq. 10).", choices=SCHEMES),
    Opt("thermal_constraints", str, ",".join(thermal.CONSTRAINTS), "Un-deposition constraints of "
        "thermal unerosion (000 §4.2): any of slope (Eq. 16), convexity (Eq. 17), rate (max "
        "un-deposition), or none."),
    METHOD,
    OUTLETS,
    SEA_LEVEL,
    DIRICHLET,
    INFLOW,
    *READING,
    FORCE,
    *RASTER_OUTPUT,
    *CHECKPOINTS,
) + parameter_options(PARAMETER_PANELS)
