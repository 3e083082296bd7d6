"""Run an ensemble: plan its members (checking everything first), run each member's pipeline as
a dask task (:mod:`unerode_cli.ensemble.engine`, :mod:`unerode_cli.pipeline.ensemble_member`),
then summarise (:mod:`unerode_cli.jobs.ensemble`). A member whose steps fail (or whose spec
fails to resolve, e.g. a swept value out of range) is recorded with its error in failures.csv
and does not stop the others.

**Resume.** ``ensemble.json`` holds the spec's content, the seed, the ``--var`` values and every
member's parameters. With ``--resume`` a member with its done marker and outputs is never rerun;
every other member starts again from an empty folder (its interrupted run is not trusted). The
members must be those of the recorded ensemble. Without ``--resume`` an existing ensemble is
refused unless ``--overwrite``, which reruns every member. Once ``ensemble.json`` is written, an
interrupted ensemble can be resumed: Ctrl-C lists the files already written (the members'
included, each once) and says to rerun with ``--resume``.

**Confinement.** The spec's paths are confined as a pipeline's
(:class:`~unerode_cli.pipeline.spec.Confinement`): the members read in the spec's folder, the
``--data`` folders, the checkout's folders and ``--allow-outside`` paths, and write in their
own folder only; a path leading elsewhere, also one that only a swept value names, refuses the
whole ensemble before any member runs. A sweep of more than :data:`~unerode_cli.ensemble.sweep.MAX_MEMBERS`
members is refused before any member is made.

**Inert axes.** A list of sea-level curves that cannot change any member's result (judged by
:mod:`unerode_cli.jobs.climate_run.sea_axes` on the members' climate-run steps) is refused
before any member runs, unless ``--allow-inert-axes``: then a warning line before the members
start and the axis under ``inert_axes`` in ``ensemble.json``. An axis that acts only through
the climate phases is told in a note.
"""

from __future__ import annotations

import contextlib
import functools
import time
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from unerode_cli import __version__
from unerode_cli.ensemble.engine import Cluster, Engine, SchedulerUnreachable, connect
from unerode_cli.ensemble.progress import Tally, short_members_warning
from unerode_cli.ensemble.sweep import Sweep
from unerode_cli.errors import InputError
from unerode_cli.io.ensemble_files import (
    DONE_FILE,
    ENSEMBLE_FILE,
    FAILURES_FILE,
    MEMBER_FILE,
    MEMBERS_FOLDER,
    MEMBERS_TABLE,
    SUMMARY_FOLDER,
    fresh_folder,
    member_folder,
    read_record,
    write_record,
    write_rows,
)
from unerode_cli.io.json_files import jsonable
from unerode_cli.io.paths import OutputPlan, active_plan, file_sha256
from unerode_cli.jobs.climate_run.sea_axes import SEA_OPTION, AxisCheck, judge_sea_axis
from unerode_cli.jobs.ensemble import MemberResult, SummaryJob, summarise
from unerode_cli.pipeline.commands import build_job, schemas
from unerode_cli.pipeline.ensemble_member import Member, Outcome, is_done, member_record, run_member
from unerode_cli.pipeline.ensemble_options import OPTIONS
from unerode_cli.pipeline.ensemble_spec import (
    Target,
    load_ensemble_spec,
    member_pipeline,
    member_spec,
    parse_sweep,
    sweep_targets,
)
from unerode_cli.pipeline.spec import CommandSchema, Confinement, OutsideError, parse_var_overrides, resolve
from unerode_cli.run.declare import declared
from unerode_cli.run.job import Job, Progress, Summary, execute

#: Raster outputs of members that the summary reads (their statistics per snapshot age).
RASTER_SUFFIXES = (".tif", ".tiff", ".exr")
#: The subcommand whose report folder holds a member's scores.
SCORING_COMMAND = "compare-terraces"


@declared("ensemble", OPTIONS)
class EnsembleJob(Job):
    """Run a pipeline spec once per member of a parameter sweep, on dask.distributed
    (``members``: the Latin hypercube samples, for sampled sweeps)."""

    @property
    def variables(self) -> dict[str, str]:
        """The ``--var`` values (name → text)."""
        return parse_var_overrides(self.var or [])

    @property
    def confinement(self) -> Confinement:
        """Where the spec's paths may lead (``--data``, ``--allow-outside``)."""
        return Confinement.from_options(self.data, self.allow_outside, "the member's folder")

    @property
    def engine(self) -> Engine:
        return Engine(self.scheduler, self.workers, self.threads_per_worker, self.retries,
                      self.scheduler_timeout)

    def plan(self, outputs: OutputPlan) -> EnsemblePlan:
        if self.resume and self.overwrite:
            raise InputError("--resume keeps the finished members and --overwrite reruns them all; give one.")
        outputs.read(self.spec)
        outputs.resumes_from_outputs = True    # finished members are kept: Ctrl-C hints --resume
        _check_spec_kept(self, outputs)
        return plan_ensemble(self, schemas())

    def run(self, planned: EnsemblePlan, progress: Progress) -> EnsembleResult:
        for text in planned.notes:
            progress.note(text)
        return run_ensemble(planned, progress.verbosity, on_note=progress.note, progress=progress)

    def write(self, result: EnsembleResult, outputs: OutputPlan) -> str:
        text = result.summary
        if self.report:
            from unerode_cli.jobs.report.job import REPORT_NAME, ReportJob

            report = ReportJob(run_dir=self.out_dir, output=self.out_dir / REPORT_NAME, overwrite=True)
            text = f"{execute(report)}\n{text}"
        return Summary(text, exit_code=1 if result.failed else 0)


@dataclass(frozen=True)
class EnsemblePlan:
    job: EnsembleJob
    members: list[Member]
    record: dict[str, Any]
    log_keys: frozenset[str]
    notes: tuple[str, ...] = ()

    @property
    def out_dir(self) -> Path:
        return self.job.out_dir


@dataclass(frozen=True)
class EnsembleResult:
    """How many members failed, and the one-line account of the run."""

    failed: int
    summary: str


def plan_ensemble(job: EnsembleJob, schemas: Mapping[str, CommandSchema]) -> EnsemblePlan:
    """Check the spec, the sweep and the output folder, and resolve every member; nothing is
    written. InputError for what stops the whole ensemble; a member whose own values do not
    resolve is planned as failed."""
    spec = load_ensemble_spec(job.spec)
    sweep = parse_sweep(spec)
    targets = sweep_targets(spec, schemas)
    try:
        values = sweep.members(job.members, job.seed)
    except ValueError as exc:
        raise InputError(f"{str(exc).rstrip('.')}.") from None
    confinement = job.confinement
    resolve(member_spec(spec, targets, {}, schemas), job.spec, schemas, job.variables,  # the spec as given
            confinement)
    record = {"unerode_cli": __version__, "spec": str(job.spec.resolve()),
              "spec_sha256": file_sha256(job.spec), "seed": job.seed, "samples": job.members,
              "vars": job.variables, "keys": list(spec.sweep), "members": values}
    _check_out_dir(job, record)
    members = []
    for index, parameters in enumerate(values):
        folder = member_folder(job.out_dir.resolve(), index)
        try:
            pipeline = member_pipeline(member_spec(spec, targets, parameters, schemas), job.spec, schemas,
                                       job.variables, folder, confinement)
            members.append(Member(index, folder, parameters, pipeline))
        except OutsideError as exc:
            raise InputError(f"member {index} ({_shown(parameters)}): {exc}") from None
        except InputError as exc:
            members.append(Member(index, folder, parameters, None, str(exc)))
    logs = frozenset(p.key for p in sweep.sampled if p.kind == "log-uniform")
    return EnsemblePlan(job, members, record, logs, _inert_axes(job, sweep, targets, members, record))


def _inert_axes(job: EnsembleJob, sweep: Sweep, targets: Mapping[str, list[Target]], members: list[Member],
                record: dict[str, Any]) -> tuple[str, ...]:
    """Refuse a sweep axis that cannot change any member's result
    (:mod:`~unerode_cli.jobs.climate_run.sea_axes`), unless ``--allow-inert-axes``: then a
    warning, and the axis in ``record``; the lines to say before the members run."""
    checks = [check for parameter in sweep.listed if len(set(parameter.values)) > 1
              for target in targets[parameter.key] if target.option == SEA_OPTION
              if (check := _sea_axis(parameter.key, target.step, members)) is not None]
    inert = [c for c in checks if c.inert]
    if inert and not job.allow_inert_axes:
        raise InputError(f"{inert[0].sentence()}; leave the axis out, or pass --allow-inert-axes to run "
                         "it anyway.")
    if inert:
        record["inert_axes"] = [c.record() for c in inert]
    return tuple([f"warning: {c.sentence()}; its members run all the same (--allow-inert-axes)."
                  for c in inert] + [f"note: {c.sentence()}." for c in checks if not c.inert])


def _sea_axis(key: str, step_name: str, members: list[Member]) -> AxisCheck | None:
    """The check of the sea-level axis ``key`` of climate-run step ``step_name``: the members'
    jobs of that step, grouped by their other swept values (None when a step does not build)."""
    groups: dict[str, list[Any]] = {}
    for member in members:
        if member.pipeline is None:
            continue
        step = next((s for s in member.pipeline.steps if s.name == step_name), None)
        if step is None or step.command != "climate-run":
            return None
        try:
            built = build_job(step.command, step.values, member.folder)
        except InputError:
            return None
        others = sorted((k, repr(v)) for k, v in member.parameters.items() if k != key)
        groups.setdefault(repr(others), []).append(built)
    return judge_sea_axis(key, step_name, list(groups.values()))


def _check_spec_kept(job: EnsembleJob, outputs: OutputPlan) -> None:
    """Refuse a spec that the ensemble would replace or delete: one of the records it writes in
    ``OUT_DIR`` (ensemble.json, failures.csv, members.csv, also through a link) or a file of
    its members' or summary folders, which a run starts afresh."""
    out = job.out_dir
    for name in (ENSEMBLE_FILE, FAILURES_FILE, MEMBERS_TABLE):
        if outputs.is_input(out / name) is not None:
            raise InputError(f"the spec {job.spec} is the ensemble's record {out / name}, which the run "
                             "rewrites; copy the spec out of the ensemble folder and run that copy.")
    spec = job.spec.resolve()
    for name in (MEMBERS_FOLDER, SUMMARY_FOLDER):
        if spec.is_relative_to((out / name).resolve()):
            raise InputError(f"the spec {job.spec} lies in {out / name}, which the run starts afresh; "
                             "copy the spec out of the ensemble folder and run that copy.")


def _shown(parameters: Mapping[str, Any]) -> str:
    return ", ".join(f"{key}={value}" for key, value in parameters.items())


def _check_out_dir(job: EnsembleJob, record: dict[str, Any]) -> None:
    out = job.out_dir
    if out.exists() and not out.is_dir():
        raise InputError(f"the ensemble folder {out} is a file.")
    if not out.exists():
        if not out.parent.is_dir():
            raise InputError(f"the folder above the ensemble folder {out} does not exist.")
        return
    earlier = read_record(out / ENSEMBLE_FILE)
    if earlier is None:
        if any(out.iterdir()):
            raise InputError(f"{out} is not empty and holds no ensemble; choose a new or empty folder.")
        return
    if job.resume:
        same = all(earlier.get(k) == v for k, v in jsonable(record).items() if k != "unerode_cli")
        if not same:
            raise InputError(f"{out} holds an ensemble of another spec or sweep (the spec's content, "
                             "--seed, --members or --var differ); resume it with the same ones, or "
                             "pass --overwrite to run every member again.")
    elif not job.overwrite:
        raise InputError(f"{out} already holds an ensemble; pass --resume to continue it or --overwrite "
                         "to run every member again.")


def run_ensemble(plan: EnsemblePlan, verbosity: int = 0,
                 on_note: Callable[[str], None] = lambda text: None,
                 progress: Progress | None = None) -> EnsembleResult:
    """Run every member not finished yet, write failures.csv, then the summary. Nothing is
    written before the engine answers. Each member that ends is a line (``on_note``) with the
    members done, running and failed and the time left, and a step of ``progress`` (a bar on
    a terminal); a worker lost or joined is a line too."""
    job = plan.job
    started = time.perf_counter()
    done = {m.index for m in plan.members if job.resume and is_done(m)}
    pending = [m for m in plan.members if m.index not in done and m.pipeline is not None]
    outcomes: dict[int, Outcome] = {}
    tally = Tally(len(pending))
    cluster = None

    def heard(i: int, outcome: Outcome | None, error: BaseException | None) -> None:
        member = pending[i]
        if outcome is None:
            outcome = Outcome(member.index, False, None, None, _task_error(error))
        outcomes[member.index] = outcome
        tally.heard(outcome.finished, outcome.wall_s)
        counts = tally.line(cluster.running() if cluster is not None else 0)
        state = f"finished in {outcome.wall_s:.1f} s" if outcome.finished else f"failed: {outcome.error}"
        on_note(f"member {member.folder.name} {state} ({counts})")
        if progress is not None:
            progress.advance(counts)

    try:
        with contextlib.ExitStack() as stack:
            if pending:
                try:
                    cluster = stack.enter_context(connect(job.engine, len(pending), on_note))
                except SchedulerUnreachable as exc:
                    raise InputError(f"the scheduler {job.engine.scheduler} {exc}.") from None
            (job.out_dir / MEMBERS_FOLDER).mkdir(parents=True, exist_ok=True)
            write_record(job.out_dir / ENSEMBLE_FILE, plan.record)
            for member in plan.members:
                if member.index in done:
                    record = read_record(member.folder / DONE_FILE) or {}
                    outcomes[member.index] = Outcome(member.index, True, record.get("wall_s"))
                elif member.pipeline is None:
                    outcomes[member.index] = _unresolved(member)
            unresolved = len(outcomes) - len(done)
            on_note(f"ensemble of {len(plan.members)} member(s) in {job.out_dir}: {len(pending)} to run"
                    + (f", {len(done)} finished earlier" if done else "")
                    + (f", {unresolved} that do not resolve" if unresolved else ""))
            if cluster is not None:
                _run_watched(cluster, pending, functools.partial(run_member, verbosity=verbosity), heard,
                             tally, on_note, progress)
    except KeyboardInterrupt:
        _note_interrupted(plan)
        raise
    ordered = [outcomes[m.index] for m in plan.members]
    failed = [o for o in ordered if not o.finished]
    write_rows(job.out_dir / FAILURES_FILE, ["member", "folder", "step", "error"],
               [{"member": o.index, "folder": plan.members[o.index].folder.name, "step": o.step,
                 "error": o.error} for o in failed])
    summary = summarise(_summary_job(plan, ordered), on_note)
    return EnsembleResult(len(failed), f"{summary}; {time.perf_counter() - started:.1f} s")


def _run_watched(cluster: Cluster, pending: list[Member], run: Callable[[Member], Outcome],
                 heard: Callable[[int, Outcome | None, BaseException | None], None], tally: Tally,
                 on_note: Callable[[str], None], progress: Progress | None) -> None:
    """Run the pending members on the cluster, a worker lost or joined said as a line, with a
    progress bar of the members; after, a warning when the members were shorter than the
    cluster's start."""
    workers = len(cluster.workers())
    if progress is not None:
        progress.start(len(pending), "ensemble members", unit="members")
    tally.started_s = time.perf_counter()
    try:
        with cluster.watched(on_note):
            cluster.run(pending, run, heard)
    finally:
        if progress is not None:
            progress.finish()
    short = short_members_warning(tally, cluster.start_s, workers)
    if short:
        warnings.warn(short, stacklevel=2)


def _task_error(error: BaseException | None) -> str:
    """What a member's task that raised (after its retries) says in failures.csv and the log."""
    text = str(error).strip().splitlines()[0] if error is not None and str(error).strip() else ""
    return f"its task stopped: {text}" if text else "its task stopped (its worker died or was stopped)"


def _note_interrupted(plan: EnsemblePlan) -> None:
    """On Ctrl-C: the members' files join the files the interrupted command lists (each once),
    and ``--resume`` is offered only when the ensemble can be resumed (ensemble.json written)."""
    outputs = active_plan()
    if not (plan.out_dir / ENSEMBLE_FILE).is_file():
        outputs.resume_flag = ""
        return
    listed = {Path(p).resolve() for p in outputs.written}
    for member in plan.members:
        found = sorted(p for p in member.folder.rglob("*") if p.is_file() and ".part" not in p.name) \
            if member.folder.is_dir() else []
        outputs.written += [p for p in found if p.resolve() not in listed]
        listed.update(p.resolve() for p in found)


def _unresolved(member: Member) -> Outcome:
    """A member whose spec does not resolve: its folder says so, and it fails."""
    fresh_folder(member.folder)
    write_record(member.folder / MEMBER_FILE, member_record(member))
    return Outcome(member.index, False, None, None, member.error)


def _summary_job(plan: EnsemblePlan, outcomes: list[Outcome]) -> SummaryJob:
    """What the summary reads: the raster outputs and score folders of the members' pipelines
    (relative to a member's folder), and each member's outcome."""
    template = next((m for m in plan.members if m.pipeline is not None), None)
    rasters: list[Path] = []
    reports: list[Path] = []
    if template is not None and template.pipeline is not None:
        for step in template.pipeline.steps:
            for path in step.outputs:
                relative = path.relative_to(template.folder)
                if path.suffix.lower() in RASTER_SUFFIXES:
                    rasters.append(relative)
                elif step.command == SCORING_COMMAND and not path.suffix:
                    reports.append(relative)
    results = tuple(MemberResult(m.index, m.folder, m.parameters, o.finished, o.wall_s, o.step, o.error)
                    for m, o in zip(plan.members, outcomes, strict=True))
    return SummaryJob(plan.out_dir, tuple(plan.record["keys"]), plan.log_keys, tuple(rasters),
                      tuple(reports), results)
