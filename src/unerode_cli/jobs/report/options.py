"""Options of `report` (declared once: CLI, pipeline, Python API)."""

from __future__ import annotations

from pathlib import Path

from unerode_cli.run.common_options import OVERWRITE
from unerode_cli.run.declare import Opt

#: The page's name in the run folder when no --output is given.
REPORT_NAME = "report.html"

OPTIONS = (
    Opt("run_dir", Path, help="A run folder: an ensemble's OUT_DIR, or a folder of climate-run, "
        "compare-terraces or other outputs.", argument=True, required=True, role="input"),
    Opt("output", Path, None, f"Write the report here (default: RUN_DIR/{REPORT_NAME}).",
        flags=("--output", "-o"), role="output", record=False),
    Opt("climate_run", Path, None, "Report on this climate-run output raster alone (its timeline, "
        "chronology and snapshots), as climate-run --report does.", role="input"),
    OVERWRITE,
)
