"""`unerode-cli landforms DEM --out DIR`: glacial landform measures (001 §7.1, Fig. 15) as a
short table, landforms.json and landforms.png."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.landforms.options import OPTIONS

landforms = command(
    "unerode_cli.jobs.landforms.job:LandformsJob",
    "Measure glacial landforms: the U-shape exponent b of the main valley's cross-sections (z = z0 + "
    "a|x − x0|^b; b ≈ 2 U, ≈ 1 V), the steps of tributaries at their junctions (hanging valleys), the "
    "lakes in closed depressions, and the hypsometry (with its shift from --before).",
    options=OPTIONS)
