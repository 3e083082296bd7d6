"""`unerode-cli glaciate DEM OUT`: glaciers grow on a DEM and erode its bed (001 §3–6)."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.glaciate.options import OPTIONS

glaciate = command(
    "unerode_cli.jobs.glaciate.job:GlacierJob",
    "Grow glaciers on a DEM (mass balance, ice flow, transport) and erode its bed (001). The progress bar "
    "shows the simulated years, their rate (y/s) and the time left; -v prints every step with the velocity "
    "solver's iterations and residual; OUT's JSON sidecar holds the ice-volume series. An ELA above every "
    "peak makes no ice: a note, and the bed is unchanged.",
    options=OPTIONS)
