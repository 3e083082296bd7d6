"""Run a resolved pipeline: each step a job in this process, a state file, ``--resume`` and
dry runs.

**Steps are jobs.** Each step is built as its subcommand's job from the step's values through
the same declarations as the command line, relative paths taken from the workdir (no change of
folder, no command line parsed), and run by the job executor with its own output plan
(:func:`unerode_cli.pipeline.commands.run_step`): its notes and summary go to stderr, bad input
gives exit code 2, a failure 1. The run log shows each step's equivalent command line.

**State file.** ``.<spec-stem>.state.json`` in the workdir, rewritten atomically after each
change. It holds, per finished step, a key (sha256 of the subcommand and its resolved command
line, the sha256 of every input file, the step's outputs and the unerode-cli version), the
sha256 of each output and when it finished (``SOURCE_DATE_EPOCH`` when set); and the
manifest of what this spec wrote: ``owned``, the outputs a step of it was started to write
(when no other file was there: see below), and ``written``, every file its steps' jobs wrote
(side files, snapshots and reports included) with its sha256 when written. Paths are stored
relative to the workdir when inside it.

**Resume rules.** With ``--resume`` a step is skipped when its record exists, its key is the
same as now (same command line, same input contents, same version) and every recorded output
still exists with the recorded sha256. Anything else runs, so a step whose option changed
reruns, and so does every later step that reads what it wrote (their input hashes change).
Without ``--resume`` every step runs. A step's record is dropped before it starts and written
when it succeeds, so a failed run resumes from the failed step.

**Overwriting.** Specs do not say ``--overwrite``: the runner passes it to a step whose
outputs exist, or that says ``overwrite: true``. A spec replaces only files it wrote itself
(in its manifest, or inside an output folder it made), whatever ``overwrite: true`` says: an
existing output that it did not write is refused before any step runs, and, while a step runs,
its job's output plan (:class:`StepPlan`) refuses to replace any other existing file (a
sidecar, a snapshot, a file of a report folder) or to write outside the spec's confinement.

Flags that only change messages (``-v``/``-q`` passed down from ``pipeline run``) and the
runner's ``--overwrite`` are not part of a step's key.
"""

from __future__ import annotations

import hashlib
import json
import shlex
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from unerode_cli import __version__
from unerode_cli.errors import InputError, RunFailure
from unerode_cli.io.checkpoints import checkpoint_path
from unerode_cli.io.json_files import read_json, write_json
from unerode_cli.io.paths import OutputPlan, check_output, file_sha256
from unerode_cli.io.provenance import record_time, sidecar_path
from unerode_cli.pipeline.spec import Confinement, OutsideError, ResolvedPipeline, ResolvedStep

STATE_VERSION = 1

#: Runs one step (its subcommand, job values and workdir, with a verbosity, and the maker of
#: the output plans its jobs run with) and returns its exit code.
Executor = Callable[[str, dict[str, Any], Path, int, Callable[[], OutputPlan]], int]


class StepFailed(Exception):
    """A step exited with a non-zero code; the pipeline stops there."""

    def __init__(self, step: str, command: str, returncode: int) -> None:
        self.step, self.command, self.returncode = step, command, returncode
        super().__init__(
            f"step '{step}' ({command}) failed with exit code {returncode}; earlier outputs and "
            "the state file are kept, so fix the cause and rerun with --resume.")

    @property
    def exit_code(self) -> int:
        """2 when the step refused bad input, 1 for any other failure."""
        return 2 if self.returncode == 2 else 1


# ---------------------------------------------------------------------------------------------
# Hashes and the state file.

def step_key(step: ResolvedStep, workdir: Path) -> str:
    """The content hash that decides whether a finished step is still up to date."""
    payload = {
        "command": step.command,
        "argv": step.argv,
        "inputs": {_rel(p, workdir): file_sha256(p) for p in step.inputs if p.exists()},
        "outputs": [_rel(p, workdir) for p in step.outputs],
        "version": __version__,
    }
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def _rel(path: Path, workdir: Path) -> str:
    try:
        return path.relative_to(workdir).as_posix()
    except ValueError:
        return str(path)


@dataclass
class State:
    """What earlier runs of this pipeline finished (see the module docstring)."""

    path: Path
    steps: dict[str, dict[str, Any]] = field(default_factory=dict)
    owned: set[str] = field(default_factory=set)
    written: dict[str, str] = field(default_factory=dict)

    @classmethod
    def load(cls, path: Path) -> State:
        """Read the state file; none yet gives an empty state."""
        if not path.exists():
            return cls(path)
        try:
            raw = read_json(path)
            steps, owned, written = raw["steps"], raw["owned"], raw.get("written", {})
            if raw.get("version") != STATE_VERSION or not isinstance(steps, dict) \
                    or not isinstance(written, dict):
                raise ValueError
        except (OSError, ValueError, KeyError, TypeError, UnicodeDecodeError):
            raise InputError(f"state file {path} is damaged; delete it to run every step again.") from None
        return cls(path, steps, set(owned), dict(written))

    def save(self) -> None:
        """Write the state atomically (a crash leaves the previous state whole)."""
        payload = {"version": STATE_VERSION, "unerode_cli": __version__, "steps": self.steps,
                   "owned": sorted(self.owned), "written": dict(sorted(self.written.items()))}
        write_json(self.path, payload)

    def wrote(self, name: str) -> bool:
        """Whether this spec wrote the file ``name`` (relative to the workdir when inside it)."""
        return name in self.owned or name in self.written

    def replaceable(self, workdir: Path) -> frozenset[Path]:
        """The files this spec wrote, as resolved paths: the ones its steps may replace (with
        the sidecar and the checkpoint of each output in ``owned``, which a killed run of its
        step may have left unrecorded)."""
        paths = [(workdir / name).resolve() for name in (*self.owned, *self.written)]
        owned = [(workdir / name).resolve() for name in self.owned]
        return frozenset([*paths, *map(sidecar_path, owned), *map(checkpoint_path, owned)])

    def record(self, plans: list[OutputPlan], workdir: Path) -> None:
        """After a step (finished, failed or interrupted): every file its jobs wrote and that
        is still there, with its sha256."""
        for plan in plans:
            for path in dict.fromkeys(plan.written):
                if path.is_file():
                    self.written[_rel(Path(path).resolve(), workdir)] = file_sha256(path)

    def up_to_date(self, step: ResolvedStep, key: str, workdir: Path) -> bool:
        """Whether a finished record matches ``key`` and its outputs are still unchanged."""
        record = self.steps.get(step.name)
        if not record or record.get("key") != key:
            return False
        outputs = record.get("outputs", {})
        for name, digest in outputs.items():
            path = workdir / name
            if not path.exists() or file_sha256(path) != digest:
                return False
        return set(outputs) == {_rel(p, workdir) for p in step.outputs}


# ---------------------------------------------------------------------------------------------
# Planning and running.

@dataclass
class Report:
    """What a run did: step names that ran and that were skipped."""

    ran: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)


def check_outputs(pipeline: ResolvedPipeline, state: State) -> None:
    """Refuse, before anything runs, an existing output this pipeline never wrote (its name is
    not in the manifest; one it wrote and that was changed since may be replaced, as ``--resume``
    does), and an existing sidecar or checkpoint of an output that it never wrote, also for a
    step that says ``overwrite: true``."""
    replaceable = state.replaceable(pipeline.workdir)
    for step in pipeline.steps:
        for out in step.outputs:
            name = _rel(out, pipeline.workdir)
            if out.exists() and not state.wrote(name):
                raise InputError(
                    f"step '{step.name}' (outputs): {name} already exists and "
                    "was not written by this pipeline, and a spec replaces only files it wrote, "
                    "whatever its overwrite says; delete it or move it away first.")
            for side in (sidecar_path(out), checkpoint_path(out)):
                if side.exists() and side.resolve() not in replaceable:
                    raise InputError(
                        f"step '{step.name}' (outputs): {_rel(side, pipeline.workdir)}, which the step "
                        "writes beside its output, already exists and was not written by this pipeline; "
                        "delete it or move it away first.")


@dataclass
class StepPlan(OutputPlan):
    """The output plan of a step's job: besides the checks of every job, an input outside the
    spec's confinement (``reads_in``) and an output outside it (``writes_in``: the workdir and
    ``--allow-outside`` paths) are refused,
    and so is replacing an existing file that the spec did not write (``replaceable``, or
    inside one of the step's output folders that the spec made, ``folders``), whatever
    ``--overwrite`` says."""

    writes_in: tuple[Path, ...] = ()
    reads_in: tuple[Path, ...] = ()
    replaceable: frozenset[Path] = frozenset()
    folders: tuple[Path, ...] = ()

    def read(self, path: Path | str) -> None:
        """Record an input, refused (OutsideError) outside the folders a step may read
        (``reads_in``): a file the spec's checks could not see, such as one a glob finds."""
        resolved = Path(path).resolve()
        if self.reads_in and not any(resolved == root or resolved.is_relative_to(root)
                                     for root in self.reads_in):
            raise OutsideError(f"input {path} leads to {resolved}, outside the workdir, the spec's folder "
                               "and the --data folders; pass --data with its folder if you trust this "
                               "spec.")
        super().read(path)

    def check_output(self, path: Path, overwrite: bool, inputs: tuple[Path, ...] = (),
                     **options: Any) -> None:
        path = Path(path)
        resolved = path.resolve()
        if not any(resolved == root or resolved.is_relative_to(root) for root in self.writes_in):
            raise OutsideError(f"output {path} leads to {resolved}, outside the workdir; a spec writes "
                               "only there (pass --allow-outside if you trust it).")
        if overwrite and path.is_file() and not self._replaceable(path, resolved) \
                and self.is_input(path, inputs) is None:
            raise InputError(f"output {path} already exists and was not written by this pipeline, and a "
                             "spec replaces only files it wrote; delete it or move it away first.")
        super().check_output(path, overwrite, inputs, **options)

    def put_in_place(self, temporary: Path, final: Path) -> None:
        """Put a finished file in place, unless ``final`` lies outside the confinement or is
        an existing file that the spec did not write (a side file that escaped the checks):
        then RunFailure, and the file there is left as it is."""
        final = Path(final)
        resolved = final.resolve()
        if not any(resolved == root or resolved.is_relative_to(root) for root in self.writes_in):
            raise RunFailure(f"{final} leads to {resolved}, outside the workdir, where a spec writes "
                             "nothing; nothing was written there")
        if final.exists() and not self._replaceable(final, resolved):
            raise RunFailure(f"{final} already exists and was not written by this pipeline; it is "
                             "left as it is, since a spec replaces only files it wrote")
        super().put_in_place(temporary, final)

    def _replaceable(self, path: Path, resolved: Path) -> bool:
        """Whether the existing file ``path`` was written by the spec or by this job."""
        return (resolved in self.replaceable or self.may_replace(path)
                or any(resolved.is_relative_to(folder) for folder in self.folders))


def step_plans(step: ResolvedStep, pipeline: ResolvedPipeline, state: State,
               made: list[OutputPlan]) -> Callable[[], OutputPlan]:
    """The maker of the output plans of ``step``'s jobs, each appended to ``made``."""
    confinement: Confinement = pipeline.confinement
    replaceable = state.replaceable(pipeline.workdir)
    folders = tuple(p for p in step.outputs if p in replaceable and p.is_dir())

    def plan() -> OutputPlan:
        made.append(StepPlan(writes_in=(pipeline.workdir, *confinement.allowed),
                             reads_in=confinement.read_roots(pipeline.workdir, pipeline.spec_path.parent),
                             replaceable=replaceable, folders=folders))
        return made[-1]

    return plan


def command_line(step: ResolvedStep, verbosity: int = 0) -> list[str]:
    """The arguments after ``unerode-cli`` for this run of ``step``: ``--overwrite`` when the
    spec says so or its outputs exist, and ``-v``/``-q`` passed down from ``pipeline run``."""
    argv = list(step.argv)
    overwrite = step.overwrite_given or any(p.exists() for p in step.outputs)
    if overwrite and step.has_overwrite:
        argv.append("--overwrite")
    if step.has_verbosity and verbosity:
        argv += ["-v"] * verbosity if verbosity > 0 else ["-q"] * -verbosity
    return argv


def job_values(step: ResolvedStep, verbosity: int = 0) -> tuple[dict[str, Any], int]:
    """The values that build the step's job for this run (``overwrite`` as in
    :func:`command_line`) and the step's verbosity (the pipeline's, plus the step's own
    ``verbose``/``quiet``)."""
    values = dict(step.values)
    own = int(values.pop("verbose", 0) or 0) - int(values.pop("quiet", 0) or 0)
    if step.has_overwrite and (step.overwrite_given or any(p.exists() for p in step.outputs)):
        values["overwrite"] = True
    return values, verbosity + own


def shown(argv: list[str]) -> str:
    """A command line as the run log and a dry run show it."""
    return shlex.join(["unerode-cli", *argv])


def dry_run(pipeline: ResolvedPipeline, resume: bool, verbosity: int = 0) -> list[str]:
    """One line per step, ``run`` or ``skip`` (what a real run would do), then the command
    line that a run with the same ``verbosity`` logs.

    A step that reads the output of a step that would run is shown as ``run``: its inputs
    will change (outputs carry the time they were written).
    """
    state = State.load(pipeline.state_path)
    check_outputs(pipeline, state)
    lines, will_run = [], set()
    for step in pipeline.steps:
        skip = (resume and not (step.produced_by & will_run)
                and state.up_to_date(step, step_key(step, pipeline.workdir), pipeline.workdir))
        if not skip:
            will_run.add(step.name)
        lines.append(f"{'skip' if skip else 'run '} {step.name}: {shown(command_line(step, verbosity))}")
    return lines


def run_pipeline(pipeline: ResolvedPipeline, resume: bool, verbosity: int = 0,
                 note: Callable[[str], None] = lambda text: None,
                 executor: Executor | None = None) -> Report:
    """Run (or skip) every step in order, each through ``executor`` (default: its job in this
    process); raises :class:`StepFailed` at the first failure."""
    from unerode_cli.pipeline.commands import run_step

    execute = executor or run_step
    state = State.load(pipeline.state_path)
    check_outputs(pipeline, state)
    if not pipeline.workdir.is_dir():
        pipeline.workdir.mkdir(parents=True)
        note(f"created the workdir {pipeline.workdir}")
    check_output(pipeline.state_path, overwrite=True)     # the pipeline's own, rewritten after each step
    report, total = Report(), len(pipeline.steps)
    note(f"pipeline {pipeline.spec_path.name}: {total} step(s) in {pipeline.workdir}")
    for i, step in enumerate(pipeline.steps, start=1):
        tag = f"[{i}/{total}] {step.name}"
        key = step_key(step, pipeline.workdir)
        if resume and state.up_to_date(step, key, pipeline.workdir):
            note(f"{tag}: skipped (unchanged since its last run)")
            report.skipped.append(step.name)
            continue
        note(f"{tag}: {shown(command_line(step, verbosity))}")
        started = time.monotonic()
        _run_step(step, pipeline, state, execute, verbosity)
        state.steps[step.name] = {
            "key": key,
            "command": step.command,
            "outputs": {_rel(p, pipeline.workdir): file_sha256(p) for p in step.outputs},
            "finished": record_time(),
        }
        state.save()
        report.ran.append(step.name)
        note(f"{tag}: done in {time.monotonic() - started:.1f} s")
    return report


def _run_step(step: ResolvedStep, pipeline: ResolvedPipeline, state: State, execute: Executor,
              verbosity: int) -> None:
    """Run one step, its record dropped first and what its jobs wrote added to the manifest
    after (also when it fails or is interrupted); StepFailed for a non-zero exit code."""
    plans: list[OutputPlan] = []
    make_plan = step_plans(step, pipeline, state, plans)      # what the spec wrote before this run
    state.steps.pop(step.name, None)
    state.owned.update(_rel(p, pipeline.workdir) for p in step.outputs)
    state.save()
    values, step_verbosity = job_values(step, verbosity)
    try:
        code = execute(step.command, values, pipeline.workdir, step_verbosity, make_plan)
    finally:
        state.record(plans, pipeline.workdir)
        state.save()
    if code != 0:
        raise StepFailed(step.name, step.command, code)
    missing = [_rel(p, pipeline.workdir) for p in step.outputs if not p.exists()]
    if missing:
        raise RuntimeError(f"step '{step.name}' finished but did not write {', '.join(missing)}.")
