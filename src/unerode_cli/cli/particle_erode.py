"""`unerode-cli particle-erode`: erode a DEM with particles (003, Hartley et al. 2024)."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.particle_erode.options import OPTIONS
from unerode_cli.particles.presets import PRESETS


def _preset_lines() -> str:
    """One paragraph per preset of 003 Table 1: what it does and its values."""
    lines = []
    for p in PRESETS.values():
        values = ", ".join(f"{k} {v:g}" for k, v in p.values.items())
        radius = f"{p.radius_cells:g}" + (f"-{p.radius_max_cells:g}" if p.radius_max_cells else "")
        field = "" if p.field == "none" else f"; velocity field: {p.field} ({p.field_medium})"
        note = f"; {p.note}" if p.note else ""
        terrain = {"heightfield": "", "sdf": ", on an implicit terrain (sdf)"}.get(p.representation,
                                                                                f", on {p.representation} voxels")
        lines.append(f"{p.name}: {p.help}. R {radius} cells or voxels, {values}, {p.particles} particles × "
                     f"{p.iterations} iterations, {p.emission} emission{terrain}{field}{note}.")
    return "\n\n".join(lines)


HELP = (
    "Erode a DEM with particles (003): each iteration emits particles (rain or a source) that "
    "fall, bounce and roll under gravity, buoyancy, Stokes drag and an optional medium velocity, "
    "detaching and depositing matter at every impact; the terrain is updated after each "
    "iteration (or at each impact: --apply per-impact). Works on a heightfield, a layered terrain (--layers, "
    "--materials), density or binary "
    "voxels (--representation; a block built from the DEM or --voxels) or an implicit terrain "
    "(--representation sdf, --sdf), whose top surface is OUTPUT; several kinds of particles may run "
    "together (--preset rain+wind+river, --kinds). Deterministic "
    "for a --seed whatever the threads. The JSON sidecar holds the mass budget (m³: detached, "
    "deposited, suspended, lost at edges, emitted) and counts.\n\nPresets (003 Table 1; R in "
    "cells of the DEM):\n\n" + _preset_lines()
)

particle_erode = command("unerode_cli.jobs.particle_erode.job:ParticleJob", HELP, options=OPTIONS)
