"""`unerode-cli ensemble SPEC.yaml OUT_DIR`: many possible pasts, one pipeline per member, on
dask.distributed (DESIGN §8). The spec and the member's life are described in
:mod:`unerode_cli.pipeline.ensemble_spec` and :mod:`unerode_cli.pipeline.ensemble_run`; each
step of a member is its subcommand's job, run in the worker's process."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.pipeline.ensemble_options import OPTIONS

ensemble = command(
    "unerode_cli.pipeline.ensemble_run:EnsembleJob",
    "Run a pipeline spec once per member of a parameter sweep, on dask.distributed.\n\n"
    "Each member runs its steps in its own folder OUT_DIR/members/NNNN (with member.json, member.log "
    "and a done marker), in the worker's process. A member that fails is recorded in failures.csv and "
    "the others go on (exit code 1 then). The summary gives, per snapshot age, rasters of the members' "
    "mean, standard deviation and 5/50/95 percentiles, and, when the spec runs compare-terraces, "
    "members.csv ranked by the terrace RMSE with scatter plots of each parameter against the scores.",
    options=OPTIONS, missing="ensemble spec {path} does not exist.")
