"""The `report` job: one self-contained ``report.html`` of what a run folder holds (the
sections of :mod:`.sections`), or of one climate-run (``climate-run --report``)."""

from __future__ import annotations

from pathlib import Path

from unerode_cli import __version__
from unerode_cli.errors import InputError
from unerode_cli.io.paths import OutputPlan
from unerode_cli.io.provenance import record_time
from unerode_cli.io.report_files import write_html
from unerode_cli.jobs.report.options import OPTIONS, REPORT_NAME
from unerode_cli.jobs.report.sections import Source, build_sections, find_sources
from unerode_cli.run.declare import declared
from unerode_cli.run.job import Job, Progress
from unerode_cli.viz.report_html import Section, render

__all__ = ["REPORT_NAME", "ReportJob"]


@declared("report", OPTIONS)
class ReportJob(Job):
    """The report of the folder ``run_dir`` into ``output`` (default: RUN_DIR/report.html), or,
    with ``climate_run``, of that climate-run raster alone."""

    @property
    def page(self) -> Path:
        """Where the page is written."""
        return self.output if self.output is not None else self.run_dir / REPORT_NAME

    def check(self, outputs: OutputPlan) -> None:
        """Refuse a missing run folder or a page that cannot be written; clear the page."""
        outputs.read(self.climate_run if self.climate_run is not None else self.run_dir)
        if self.climate_run is None and not self.run_dir.is_dir():
            raise InputError(f"the run folder {self.run_dir} does not exist or is not a folder.")
        if self.page.suffix.lower() not in (".html", ".htm"):
            raise InputError(f"the report is an HTML page: {self.page.name} does not end in .html.")
        outputs.check_output(self.page, self.overwrite)

    def sources(self) -> list[Source]:
        """What the page shows (InputError when the folder holds nothing unerode-cli wrote)."""
        if self.climate_run is not None:
            return [Source("climate-run", self.climate_run)]
        found = find_sources(self.run_dir)
        if not found:
            raise InputError(f"{self.run_dir} holds nothing unerode-cli wrote (no ensemble, climate-run "
                             "timeline, terrace report or raster with its JSON sidecar).")
        return found

    def plan(self, outputs: OutputPlan) -> list[Source]:
        self.check(outputs)
        return self.sources()

    def run(self, planned: list[Source], progress: Progress) -> list[Section]:
        """The sections: previews and plots drawn, tables read."""
        return build_sections(planned, self.page.parent)

    def write(self, result: list[Section], outputs: OutputPlan) -> str:
        """Render and write the page (atomically); the summary names it and its size."""
        where = self.climate_run if self.climate_run is not None else self.run_dir
        subtitle = f"{where.resolve()} — unerode-cli {__version__}, {record_time()[:16].replace('T', ' ')}"
        text = render(f"unerode-cli report: {where.name}", subtitle, result)
        write_html(self.page, text)
        return f"report: wrote {self.page} ({len(result)} section(s), {len(text.encode()) / 1e3:.0f} kB)"
