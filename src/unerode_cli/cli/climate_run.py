"""`unerode-cli climate-run`: (un)erode a DEM along a paleo-climate chronology (000 §5); with
--report, the report of the run (`unerode-cli report`) when it has finished."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.climate_run.options import OPTIONS

climate_run = command(
    "unerode_cli.jobs.climate_run.job:ClimateJob",
    "Run the processes along a chronology: per-step sea level, climate phase and parameters (000 §5), with a "
    "coast that follows sea level. Writes the DEM at --to, snapshots (tagged with age, sea level and phase), "
    "OUTPUT_timeline.csv and OUTPUT_chronology.png. With --process glacial, glaciers grow and erode forward "
    "in time (glaciate's model, 001), their ELA and the sea level of the ground without ice both from the "
    "chronology.",
    options=OPTIONS)
