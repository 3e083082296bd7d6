"""`unerode-cli erode` and `unerode-cli unerode`: run surface processes forward or backward."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.erode.options import OPTIONS

erode = command(
    "unerode_cli.jobs.erode.job:ErosionJob",
    "Erode a DEM: run the processes forward in time (fluvial, thermal, hillslope, debris flow).",
    options=OPTIONS)
unerode = command(
    "unerode_cli.jobs.erode.job:UnerosionJob",
    "Unerode a DEM: run the processes backward in time (000 §3.2, slope limiter).",
    options=OPTIONS)
