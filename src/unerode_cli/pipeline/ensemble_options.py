"""Options of `ensemble` (declared once: CLI, provenance in ensemble.json, Python API)."""

from __future__ import annotations

from pathlib import Path

from unerode_cli.run.declare import Opt
from unerode_cli.run.values import Number

ENGINE_PANEL = "Engine (dask.distributed)"
SWEEP_PANEL = "Sweep"

OPTIONS = (
    Opt("spec", Path, help="Ensemble spec (YAML): a pipeline spec (version, vars, steps) with a sweep block.",
        argument=True, required=True, role="input"),
    Opt("out_dir", Path, help="Output folder of the ensemble: members/NNNN/, members.csv, failures.csv, "
        "summary/.", argument=True, required=True, role="other", record=False),
    Opt("members", int, None, "Latin hypercube samples of the sampled parameters, crossed with every "
        "combination of the lists.", minimum=1, panel=SWEEP_PANEL),
    Opt("seed", int, 0, "Seed of the Latin hypercube sampling (recorded in ensemble.json).",
        panel=SWEEP_PANEL),
    Opt("var", str, None, "Set a variable declared under vars: NAME=VALUE (repeatable).", kind="multiple",
        panel=SWEEP_PANEL),
    Opt("allow_inert_axes", bool, False, "Run a sweep axis that cannot change any member's result (e.g. "
        "sea-level curves on a domain the sea never reaches, with the same climate phases), which is "
        "refused otherwise; it is recorded in ensemble.json.", kind="flag", panel=SWEEP_PANEL),
    Opt("data", Path, None, "A folder whose files the members' steps may read, besides the spec's folder "
        "(repeatable).", kind="multiple", panel=SWEEP_PANEL, record=False),
    Opt("allow_outside", Path, None, "A file or folder outside the spec's folder that you trust this spec to "
        "read (repeatable).", kind="multiple", panel=SWEEP_PANEL, record=False),
    Opt("workers", int, None, "Worker processes of the local cluster (default: one per core, at most one "
        "per member).", minimum=1, panel=ENGINE_PANEL, record=False),
    Opt("threads_per_worker", int, None, "numba threads of each member's run (default: the cores shared "
        "among the workers; at most cores ÷ workers on a local cluster; 1 with --scheduler).", minimum=1,
        panel=ENGINE_PANEL, record=False),
    Opt("scheduler", str, None, "Address of a running dask scheduler (tcp://HOST:PORT) instead of a local "
        "cluster; its workers must read the inputs and OUT_DIR at the same paths.", panel=ENGINE_PANEL,
        record=False),
    Opt("scheduler_timeout", float, 10.0, "Seconds to wait for --scheduler to answer.",
        parser=Number("s", 0.0, above=True), panel=ENGINE_PANEL, record=False),
    Opt("retries", int, 1, "Times a member's task is run again when its worker dies or the task raises.",
        minimum=0, panel=ENGINE_PANEL, record=False),
    Opt("resume", bool, False, "Continue an ensemble in OUT_DIR: finished members are kept, the others run "
        "(from their start).", kind="flag", record=False),
    Opt("report", bool, False, "Also write OUT_DIR/report.html (see unerode-cli report).", kind="flag",
        record=False),
    Opt("overwrite", bool, False, "Replace an existing output.", kind="flag", panel="Outputs", record=False),
)
