"""`unerode-cli compare-terraces`: simulated past riverbeds against dated terraces and incision
rates (000 §6.3)."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.compare_terraces.options import OPTIONS

compare_terraces = command(
    "unerode_cli.jobs.compare_terraces.job:TerraceJob",
    "Compare the riverbeds of climate-run snapshots with dated terraces and incision rates.\n\n"
    "Heights are those of each snapshot's riverbed above today's, along the river; each observation is "
    "compared at its place (x,y or chainage) or with the river's mean.",
    options=OPTIONS)
