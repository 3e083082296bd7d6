"""`unerode-cli report RUN_DIR`: a self-contained HTML report of a run folder."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.report.options import OPTIONS

report = command(
    "unerode_cli.jobs.report.job:ReportJob",
    "Write one self-contained report.html of what a run folder holds: previews at each snapshot, chronology "
    "and timeline plots, the mass budget, parameters and history of climate-runs; terrace fits; an "
    "ensemble's summary maps, ranking and scatter plots. Images are embedded: the page needs no other file "
    "and no network.", options=OPTIONS,
    missing="the run folder {path} does not exist or is not a folder.")
