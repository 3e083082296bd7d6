"""`unerode-cli report RUN_DIR`: a self-contained HTML report of a run folder."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import Overwrite, Quiet, Verbose


def report(
    run_dir: Annotated[Path, typer.Argument(help="A run folder: an ensemble's OUT_DIR, or a folder of climate-run, compare-terraces or other outputs.")],
    output: Annotated[Path | None, typer.Option("--output", "-o", help="Write the report here (default: RUN_DIR/report.html).")] = None,
    overwrite: Overwrite = False,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Write one self-contained report.html of what a run folder holds: previews at each snapshot, chronology and timeline plots, the mass budget, parameters and history of climate-runs; terrace fits; an ensemble's summary maps, ranking and scatter plots. Images are embedded: the page needs no other file and no network."""
    with reported_errors(verbose - quiet):
        from unerode_cli.cli.common import SUMMARY, say
        from unerode_cli.jobs.report import REPORT_NAME, ReportJob, plan_report, write_report

        job = ReportJob(run_dir, output or run_dir / REPORT_NAME, overwrite)
        plan_report(job)
        say(write_report(job), verbose - quiet, SUMMARY)
