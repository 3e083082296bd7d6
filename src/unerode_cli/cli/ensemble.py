"""`unerode-cli ensemble SPEC.yaml OUT_DIR`: many possible pasts, one pipeline per member, on
dask.distributed (DESIGN §8). The spec and the member's life are described in
:mod:`unerode_cli.pipeline.ensemble_spec` and :mod:`unerode_cli.pipeline.ensemble_run`; this
module parses the command line and runs each step of a member in the worker's process."""

from __future__ import annotations

import contextlib
import functools
import os
import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from unerode_cli.cli.errors import EXIT_RUNTIME, reported_errors
from unerode_cli.cli.options import Overwrite, Quiet, Verbose
from unerode_cli.cli.values import Number

ENGINE_PANEL = "Engine (dask.distributed)"
SWEEP_PANEL = "Sweep"


def ensemble(
    spec: Annotated[Path, typer.Argument(help="Ensemble spec (YAML): a pipeline spec (version, vars, steps) with a sweep block.")],
    out_dir: Annotated[Path, typer.Argument(help="Output folder of the ensemble: members/NNNN/, members.csv, failures.csv, summary/.")],
    members: Annotated[int | None, typer.Option("--members", min=1, help="Latin hypercube samples of the sampled parameters, crossed with every combination of the lists.", rich_help_panel=SWEEP_PANEL)] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the Latin hypercube sampling (recorded in ensemble.json).", rich_help_panel=SWEEP_PANEL)] = 0,
    var: Annotated[list[str] | None, typer.Option("--var", help="Set a variable declared under vars: NAME=VALUE (repeatable).", rich_help_panel=SWEEP_PANEL)] = None,
    workers: Annotated[int | None, typer.Option("--workers", min=1, help="Worker processes of the local cluster (default: one per core, at most one per member).", rich_help_panel=ENGINE_PANEL)] = None,
    threads_per_worker: Annotated[int | None, typer.Option("--threads-per-worker", min=1, help="numba threads of each member's run (default: the cores shared among the workers; at most cores ÷ workers on a local cluster; 1 with --scheduler).", rich_help_panel=ENGINE_PANEL)] = None,
    scheduler: Annotated[str | None, typer.Option("--scheduler", help="Address of a running dask scheduler (tcp://HOST:PORT) instead of a local cluster; its workers must read the inputs and OUT_DIR at the same paths.", rich_help_panel=ENGINE_PANEL)] = None,
    scheduler_timeout: Annotated[float, typer.Option("--scheduler-timeout", parser=Number("s", 0.0, above=True), help="Seconds to wait for --scheduler to answer.", rich_help_panel=ENGINE_PANEL)] = 10.0,
    retries: Annotated[int, typer.Option("--retries", min=0, help="Times a member's task is run again when its worker dies or the task raises.", rich_help_panel=ENGINE_PANEL)] = 1,
    resume: Annotated[bool, typer.Option("--resume", help="Continue an ensemble in OUT_DIR: finished members are kept, the others run (from their start).")] = False,
    report: Annotated[bool, typer.Option("--report", help="Also write OUT_DIR/report.html (see unerode-cli report).")] = False,
    overwrite: Overwrite = False,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
) -> None:
    """Run a pipeline spec once per member of a parameter sweep, on dask.distributed.

    Each member runs its steps in its own folder OUT_DIR/members/NNNN (with member.json, member.log and a done marker), in the worker's process. A member that fails is recorded in failures.csv and the others go on (exit code 1 then). The summary gives, per snapshot age, rasters of the members' mean, standard deviation and 5/50/95 percentiles, and, when the spec runs compare-terraces, members.csv ranked by the terrace RMSE with scatter plots of each parameter against the scores.
    """
    verbosity = verbose - quiet
    with reported_errors(verbosity):
        from unerode_cli.cli.common import SUMMARY, say
        from unerode_cli.cli.pipeline_cmd import command_schemas
        from unerode_cli.ensemble.engine import Engine
        from unerode_cli.jobs.report import REPORT_NAME, ReportJob, plan_report, write_report
        from unerode_cli.pipeline.ensemble_run import EnsembleJob, plan_ensemble, run_ensemble
        from unerode_cli.pipeline.spec import parse_var_overrides

        if resume and overwrite:
            from unerode_cli.errors import InputError

            raise InputError("--resume keeps the finished members and --overwrite reruns them all; give one.")
        engine = Engine(scheduler, workers, threads_per_worker, retries, scheduler_timeout)
        job = EnsembleJob(spec, out_dir, members, seed, parse_var_overrides(var or []), resume, overwrite, engine)
        plan = plan_ensemble(job, command_schemas())
        result = run_ensemble(plan, run_in_process, verbosity, on_note=lambda text: say(text, verbosity))
        if report:
            report_job = ReportJob(out_dir, out_dir / REPORT_NAME, overwrite=True)  # the ensemble's own
            plan_report(report_job)
            say(write_report(report_job), verbosity)
        say(result.summary, verbosity, SUMMARY)
        if result.failed:
            raise typer.Exit(EXIT_RUNTIME)


def run_in_process(argv: list[str], workdir: Path) -> int:
    """Run ``unerode-cli ARGV`` in this process with ``workdir`` as the working folder; its exit
    code. What the command prints goes to this process's streams; its history records ARGV."""
    import click

    previous, saved_argv = Path.cwd(), sys.argv
    os.chdir(workdir)
    sys.argv = ["unerode-cli", *argv]
    try:
        code: Any = _root_command().main(argv, prog_name="unerode-cli", standalone_mode=False)
    except click.ClickException as exc:
        exc.show()
        code = exc.exit_code
    except click.exceptions.Abort:
        code = 1
    except SystemExit as exc:
        code = exc.code
    finally:
        sys.argv = saved_argv
        os.chdir(previous)
        with contextlib.suppress(ValueError):
            sys.stdout.flush()
    return code if isinstance(code, int) else 0


@functools.cache
def _root_command() -> Any:
    from unerode_cli.cli.app import app

    return typer.main.get_command(app)
