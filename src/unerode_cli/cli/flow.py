"""`unerode-cli flow DEM OUT`: discharge, drainage area or D8 receivers of a DEM."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.flow.options import OPTIONS

flow = command("unerode_cli.jobs.flow.job:FlowJob",
               "Route water over a DEM (depressions are routed across, the DEM is not changed).",
               options=OPTIONS)
