"""The table of subcommands as jobs: name → job class and declared options.

Every front door uses it: the command line registers one typer command per entry, a pipeline
spec is checked against the declarations (:func:`schemas`) and its steps are built and run as
jobs in this process (:func:`run_step`), and the Python API builds the same jobs. Job modules
are imported when a job is built; the options modules are light (no numba, no GDAL).
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from unerode_cli.errors import InputError, RunFailure, WriteFailure
from unerode_cli.io.paths import OutputPlan
from unerode_cli.io.provenance import recorded_relative_to
from unerode_cli.pipeline.spec import CommandSchema, ParamSchema
from unerode_cli.run.declare import Opt, build
from unerode_cli.run.job import Progress, StreamProgress, Summary, execute
from unerode_cli.run.unexpected import unexpected


@dataclass(frozen=True)
class JobEntry:
    """Where a subcommand's job class and its options live (``module:attribute``)."""

    job: str
    options: str

    def job_class(self) -> Any:
        module, name = self.job.split(":")
        return getattr(importlib.import_module(module), name)

    def declarations(self) -> tuple[Opt, ...]:
        module, name = self.options.split(":")
        return getattr(importlib.import_module(module), name)


def _entry(package: str, job_class: str, options: str = "OPTIONS") -> JobEntry:
    return JobEntry(f"unerode_cli.jobs.{package}.job:{job_class}",
                    f"unerode_cli.jobs.{package}.options:{options}")


#: Subcommand → its job, in the order of ``unerode-cli --help``.
JOBS: dict[str, JobEntry] = {
    "info": _entry("info", "InfoJob"),
    "convert": _entry("convert", "ConvertJob"),
    "preview": _entry("preview", "PreviewJob"),
    "synth": _entry("synth", "SynthJob"),
    "flow": _entry("flow", "FlowJob"),
    "erode": _entry("erode", "ErosionJob"),
    "unerode": _entry("erode", "UnerosionJob"),
    "diff": _entry("diff", "DiffJob"),
    "hypsometry": _entry("hypsometry", "HypsometryJob"),
    "glaciate": _entry("glaciate", "GlacierJob"),
    "climate-run": _entry("climate_run", "ClimateJob"),
    "compare-terraces": _entry("compare_terraces", "TerraceJob"),
    "particle-erode": _entry("particle_erode", "ParticleJob"),
    "landforms": _entry("landforms", "LandformsJob"),
    "sandstone": _entry("sandstone", "SandstoneJob"),
    "report": _entry("report", "ReportJob"),
}

#: The display options every command takes besides its job's (not job fields).
VERBOSITY = {"verbose": ("--verbose", "-v"), "quiet": ("--quiet", "-q")}


def schema(name: str, declarations: tuple[Opt, ...]) -> CommandSchema:
    """What a pipeline spec may give subcommand ``name``: its declarations as schemas."""
    arguments, options = [], {}
    for opt in declarations:
        param = _schema(opt)
        if opt.argument:
            arguments.append(param)
            continue
        for flag in opt.all_flags:
            if flag.startswith("--"):
                options[flag[2:]] = param
                options.setdefault(flag[2:].replace("_", "-"), param)
    for name_, flags in VERBOSITY.items():
        options[name_] = ParamSchema(name_, flags, kind="count", type="int")
    return CommandSchema(name, tuple(arguments), options)


def _schema(opt: Opt) -> ParamSchema:
    if opt.choices:
        type_name = "choice"
    elif opt.type is Path:
        type_name = "path"
    elif opt.type in (int, float) and opt.kind == "value":
        type_name = opt.type.__name__
    else:
        type_name = "str"
    kind = "multiple" if opt.kind == "multiple" else opt.kind
    return ParamSchema(
        name=opt.name, flags=opt.all_flags if not opt.argument else (), kind=kind, type=type_name,
        role=opt.role if type_name == "path" else "other", choices=opt.choices,
        minimum=opt.minimum if opt.type is int else None, maximum=opt.maximum if opt.type is int else None,
        required=opt.required, off_flags=(opt.off_flag,) if opt.off_flag else (),
        parse=opt.parser.parse if opt.parser is not None else None)


def schemas() -> dict[str, CommandSchema]:
    """Every subcommand a pipeline step may run, as :class:`CommandSchema` objects."""
    return {name: schema(name, entry.declarations()) for name, entry in JOBS.items()}


def absolute(opt: Opt, value: Any, workdir: Path) -> Any:
    """``value`` of ``opt`` with relative paths made absolute against ``workdir``: path options,
    and text options (a parameter raster, an ELA table) whose text names a file there."""
    if value is None or isinstance(value, bool):
        return value
    if isinstance(value, list):
        return [absolute(opt, item, workdir) for item in value]
    if opt.type is Path:
        path = Path(value).expanduser()
        return path if path.is_absolute() else workdir / path
    if opt.type is str and not opt.choices and isinstance(value, str) and value:
        try:
            float(value)
        except ValueError:
            candidate = workdir / value
            if not Path(value).is_absolute() and candidate.exists():
                return str(candidate)
    return value


def build_job(command: str, values: Mapping[str, Any], workdir: Path) -> Any:
    """The job of subcommand ``command`` from a step's ``values`` (field → text or value),
    relative paths taken from ``workdir``; InputError (one sentence) when a value is bad."""
    entry = JOBS[command]
    declarations = {opt.name: opt for opt in entry.declarations()}
    job_class = entry.job_class()
    given = {name: absolute(declarations[name], value, workdir)
             for name, value in values.items() if name in declarations}
    try:
        return build(job_class, given)
    except ValueError as exc:
        raise InputError(f"{command}: {str(exc).rstrip('.')}.") from None


def follow_ups(job: Any) -> list[Any]:
    """The jobs that run after ``job`` because it asks for them: ``climate-run --report`` → the
    report of the finished run (a run stopped before its end has none yet)."""
    if getattr(job, "COMMAND", "") == "climate-run" and job.report:
        from unerode_cli.io.checkpoints import checkpoint_path
        from unerode_cli.jobs.climate_run.forcing import report_path
        from unerode_cli.jobs.report.job import ReportJob

        if not checkpoint_path(job.output).exists():
            return [ReportJob(run_dir=job.output.parent, output=report_path(job.output),
                              overwrite=job.overwrite or job.resume, climate_run=job.output)]
    return []


def run_job(job: Any, progress: Progress | None = None, outputs: OutputPlan | None = None,
            plans: Callable[[], OutputPlan] | None = None) -> str:
    """Run ``job`` (:func:`~unerode_cli.run.job.execute`), then its :func:`follow_ups`, each with
    its own output plan (``outputs`` for ``job``, else made by ``plans``, else a new one); the
    summaries, one per line (the first keeps its exit code)."""
    summary = execute(job, progress, outputs or (plans() if plans else None))
    extra = [execute(follow, progress, plans() if plans else None) for follow in follow_ups(job)]
    if not extra:
        return summary
    return Summary("\n".join(text for text in (summary, *extra) if text), getattr(summary, "exit_code", 0))


def run_step(command: str, values: Mapping[str, Any], workdir: Path, verbosity: int = 0,
             plans: Callable[[], OutputPlan] | None = None) -> int:
    """Build and run one step's job in this process, with the output plans ``plans`` makes
    (default: new ones); its exit code (0, 2 for bad input, 1 for a failure, or the one the
    job's summary asks for), with the job's notes, summary and error on stderr as the command
    line says them. The history its outputs carry names the files in ``workdir`` by their
    paths relative to it, as the spec does."""
    progress = StreamProgress(verbosity)
    try:
        job = build_job(command, values, workdir)
        with recorded_relative_to(workdir):
            summary = run_job(job, progress, plans=plans)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except WriteFailure as exc:
        print(f"error: {str(exc).rstrip('.')}; the files written before it are kept.", file=sys.stderr)
        return 1
    except RunFailure as exc:
        print(f"error: {str(exc).rstrip('.')}; nothing is kept.", file=sys.stderr)
        return 1
    except Exception as exc:  # noqa: BLE001 - a step's failure stops the pipeline, not the process
        print(f"error: {unexpected(exc)}.", file=sys.stderr)
        return 1
    if summary and verbosity >= -1:
        print(summary, file=sys.stderr)
    return int(getattr(summary, "exit_code", 0))
