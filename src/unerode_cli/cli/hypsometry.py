"""`unerode-cli hypsometry DEM...`: elevation histograms (001 Fig. 15) as CSV and PNG."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.hypsometry.options import OPTIONS

hypsometry = command("unerode_cli.jobs.hypsometry.job:HypsometryJob",
                     "Distribution of elevations: share of the area per elevation bin, hypsometric integral "
                     "HI = (mean − min)/(max − min) and hypsometric maximum (the fullest bin), printed per "
                     "DEM.", options=OPTIONS)
