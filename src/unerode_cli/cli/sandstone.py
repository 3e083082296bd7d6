"""`unerode-cli sandstone`: erode a 3D sandstone rock of particles (002, Arenite)."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.sandstone.options import OPTIONS, PRESET_NAMES

sandstone = command(
    "unerode_cli.jobs.sandstone.job:SandstoneJob",
    "Erode a 3D sandstone rock (002, Arenite): particles sampled in a scene (CSG of boxes, spheres "
    f"and cylinders with sediment layers, painted regions and noise), a preset ({', '.join(PRESET_NAMES)}) or a "
    "DEM extruded into a block; each frame computes the stress (MLS-MPM, corotated), switches the "
    "erodibility where the rock interlocks (compressive stress -tr σ above I), erodes the surface by "
    "wind abrasion and deflation and by the shear stress of the water routed over it in 3D (rain "
    "and sources), deposits what eroded on stable cells, and lets rock that erosion cut off the "
    "ground fall and land as debris. Deterministic for a "
    "--seed whatever the threads.",
    options=OPTIONS)
