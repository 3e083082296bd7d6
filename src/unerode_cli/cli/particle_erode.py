"""`unerode-cli particle-erode`: erode a DEM with particles (003, Hartley et al. 2024)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import (
    METRES,
    Band,
    Channel,
    Cog,
    CreationOptions,
    Dtype,
    DtypeOpt,
    InputDem,
    OutputDem,
    Overwrite,
    Preview,
    Quiet,
    Seed,
    Verbose,
)
from unerode_cli.cli.parameter_options import with_parameter_options
from unerode_cli.cli.values import Number
from unerode_cli.particles.parameters import PARAMETERS
from unerode_cli.particles.presets import PRESETS

PANEL = "Particle parameters (003 §3-4): a value given replaces the preset's; 'default' is the value a preset does not set"


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


@with_parameter_options({PANEL: PARAMETERS})
def particle_erode(
    source: InputDem,
    output: OutputDem,
    preset: Annotated[str | None, typer.Option("--preset", help="Preset of 003 Table 1: rain, meanders, river, landslide, coastal, wind, underwater, volcano, karst or tunnel (described above), or several joined by + (e.g. rain+wind+river: each kind of particles with its preset's count and values, 003 Fig. 8); every value can be overridden. Default: rain.", rich_help_panel="Run")] = None,
    kinds: Annotated[Path | None, typer.Option("--kinds", help="YAML of the kinds of particles of the run, in order (each: preset, particles per iteration, velocity, parameters; optional iterations; see the README); instead of --preset.", rich_help_panel="Run")] = None,
    particles: Annotated[int | None, typer.Option("--particles", min=1, help="Particles emitted per iteration (default: the preset's).", rich_help_panel="Run")] = None,
    iterations: Annotated[int | None, typer.Option("--iterations", min=1, help="Iterations; the terrain is updated after each (at each impact with --apply per-impact; default: the preset's).", rich_help_panel="Run")] = None,
    seed: Seed = 0,
    threads: Annotated[int | None, typer.Option("--threads", min=1, help="Numba threads (default: all cores); the result does not depend on it.", rich_help_panel="Run")] = None,
    apply: Annotated[str, typer.Option("--apply", help="When impacts alter the terrain: per-iteration (every particle of an iteration traced in parallel against the terrain as it stood before the iteration, then their impacts applied in order: fast, but many particles per iteration all settle in the same hollows and pile up there) or per-impact (each impact applied as it happens, 003 §3: a particle meets what it and every particle before it did, but the particles are traced one after the other, on one thread; heightfield, density and binary only). Both conserve mass and are deterministic.", rich_help_panel="Run")] = "per-iteration",
    emission: Annotated[str | None, typer.Option("--emission", help="rain (over the domain or --rain-mask) or source (--source); default: the preset's, source when --source is given.", rich_help_panel="Emission")] = None,
    sources: Annotated[list[str] | None, typer.Option("--source", help="Source point X,Y in the DEM's CRS units (repeat for the vertices of a line), or a GeoJSON/WKT line file; default: the highest cell.", rich_help_panel="Emission")] = None,
    spread: Annotated[float | None, typer.Option("--spread", parser=Number("m", 0.0), help="Source particles start uniformly within this distance (m) of the point or line (default: the particle radius R).", rich_help_panel="Emission")] = None,
    rain_mask: Annotated[Path | None, typer.Option("--rain-mask", help="Raster on the DEM's grid of rain weights (≥ 0, unitless): where rain particles start.", rich_help_panel="Emission")] = None,
    emission_velocity: Annotated[str | None, typer.Option("--emission-velocity", help="Initial particle velocity VE,VN[,VU] (m/s, east, north, up; default 0).", rich_help_panel="Emission")] = None,
    velocity: Annotated[str | None, typer.Option("--velocity", help="Medium velocity field (003 Eq. 8): uniform:VE,VN[,VU] (m/s), sin[:AMPLITUDE,WAVELENGTH] (a northward AMPLITUDE·sin(2πx/WAVELENGTH), m/s and m: 003 Table 1 meanders; default 1 m/s and a quarter of the DEM's width), or a 2/3-band raster on the DEM's grid (east, north[, up] m/s). Default: still medium.", rich_help_panel="Medium")] = None,
    velocity_medium: Annotated[str | None, typer.Option("--velocity-medium", help="Where the velocity field acts: both, air (above --sea-level) or water (below); default: the preset's.", rich_help_panel="Medium")] = None,
    sea_level: Annotated[float | None, typer.Option("--sea-level", parser=METRES, help="Elevation (m) below which the medium is water (density rho_water, viscosity mu_water); default: air everywhere.", rich_help_panel="Medium")] = None,
    representation: Annotated[str | None, typer.Option("--representation", help="Terrain representation (003 §4): heightfield, layers (--layers), density (density voxels, 003 Eq. 13), binary (binary voxels with hit counts, Eq. 14) or sdf (an implicit terrain: a signed distance function altered by metaballs, Eq. 11). Default: that of --voxels, sdf with --sdf, layers with --layers, else the preset's (heightfield; karst: binary, tunnel: density, meanders: sdf).", rich_help_panel="Terrain")] = None,
    sdf: Annotated[Path | None, typer.Option("--sdf", help="Implicit terrain: a YAML scene of primitives in the DEM's CRS (the DEM's surface, plane, box, sphere, capsule; union, difference; see the README) instead of the DEM's surface alone; the DEM gives the columns.", rich_help_panel="Terrain")] = None,
    voxel_size: Annotated[float | None, typer.Option("--voxel-size", parser=Number("m", 0.0, above=True), help="Voxels: size (m) of the block built from the DEM, or of the node cache of an implicit terrain (default: the DEM's cell size); preset radii are in voxels.", rich_help_panel="Voxels")] = None,
    depth: Annotated[float | None, typer.Option("--depth", parser=Number("m", 0.0), help="Voxels: the block reaches this far (m) below the DEM's lowest cell (default 10 voxels).", rich_help_panel="Voxels")] = None,
    headroom: Annotated[float | None, typer.Option("--headroom", parser=Number("m", 0.0), help="Voxels: the block reaches this far (m) above the DEM's highest cell, room for deposits (default 10 voxels).", rich_help_panel="Voxels")] = None,
    voxels: Annotated[Path | None, typer.Option("--voxels", help="Voxels: read the volume from this .npz (arrays origin, voxel_size, density or solid + hits, optional material, material_names, valid, crs; see the README) instead of building a block from the DEM.", rich_help_panel="Voxels")] = None,
    volume_out: Annotated[Path | None, typer.Option("--volume-out", help="Voxels: write the altered volume (.npz, the --voxels format).", rich_help_panel="Voxels")] = None,
    mesh: Annotated[Path | None, typer.Option("--mesh", help="Voxels: write the closed surface mesh of the altered ground (.ply or .obj, m from its origin comment, coloured by material; needs scikit-image).", rich_help_panel="Voxels")] = None,
    memory_budget: Annotated[float, typer.Option("--memory-budget", parser=Number("GiB", 0.0, above=True), help="Voxels: refuse a volume whose run would need more memory than this (GiB).", rich_help_panel="Voxels")] = 4.0,
    hits_per_voxel: Annotated[float | None, typer.Option("--hits-per-voxel", parser=Number("hits", 0.0, above=True), help="Binary voxels: α of 003 Eq. 14, hits per voxel volume of matter a voxel receives (default 1000000: shares of a millionth of a voxel still count).", rich_help_panel="Voxels")] = None,
    hits_threshold: Annotated[int | None, typer.Option("--hits-threshold", min=1, help="Binary voxels: C, the hits at which a voxel flips (003 Eq. 14; default 1000000, with the default α a voxel's worth of matter).", rich_help_panel="Voxels")] = None,
    layers: Annotated[Path | None, typer.Option("--layers", help="Multi-band raster on the DEM's grid of layer thicknesses (m), bottom layer first (003 §4.2); the base of the stack is the DEM minus their sum.", rich_help_panel="Layered terrain")] = None,
    materials: Annotated[Path | None, typer.Option("--materials", help="Materials table (CSV: name, erodibility K_eps in Pa^-a, critical_stress tau_c in Pa), or for voxels a YAML of 3D material layers (materials, horizons by elevation, deposit, eroded rules; see the README); replaces --k-eps and --tau-c.", rich_help_panel="Layered terrain")] = None,
    layer_materials: Annotated[str | None, typer.Option("--layer-materials", help="Material name of each band, bottom first, comma-separated (default: the band descriptions, else the table's rows in order).", rich_help_panel="Layered terrain")] = None,
    deposit_material: Annotated[str | None, typer.Option("--deposit-material", help="Material that deposits become (default: the top layer's or horizon's).", rich_help_panel="Layered terrain")] = None,
    layers_out: Annotated[Path | None, typer.Option("--layers-out", help="Output layers (GeoTIFF, thicknesses in m, bottom first, the deposit layer on top, band descriptions = materials); default OUTPUT_layers.tif.", rich_help_panel="Layered terrain")] = None,
    change_map: Annotated[Path | None, typer.Option("--change-map", help="Write the elevation change Δh (m): < 0 erosion, > 0 deposition.", rich_help_panel="Outputs")] = None,
    paths: Annotated[Path | None, typer.Option("--paths", help="Write a GeoJSON of sampled particle paths: LineStrings x, y (DEM's CRS), z (m), with id, fate and times (s).", rich_help_panel="Outputs")] = None,
    path_count: Annotated[int, typer.Option("--path-count", min=1, help="Paths sampled for --paths, evenly over the run's particles.", rich_help_panel="Outputs")] = 100,
    path_stride: Annotated[int, typer.Option("--path-stride", min=1, help="Record a path point every this many time steps (and at death).", rich_help_panel="Outputs")] = 4,
    band: Band = None,
    channel: Channel = None,
    dtype: DtypeOpt = Dtype.float32,
    cog: Cog = False,
    co: CreationOptions = None,
    overwrite: Overwrite = False,
    preview: Preview = None,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
    parameter_values: dict[str, str | None] | None = None,
) -> None:
    with reported_errors(verbose - quiet):
        from unerode_cli.cli.common import SUMMARY, say
        from unerode_cli.cli.progress import progress_bar
        from unerode_cli.jobs.particle_erode import ParticleJob, plan, run_job
        from unerode_cli.run.outputs import Outputs

        job = ParticleJob(
            source=source, outputs=Outputs.from_cli(output, dtype.value, cog, co, overwrite, preview),
            preset=preset, particles=particles, iterations=iterations, seed=seed,
            emission=emission, sources=tuple(sources or ()), spread=spread, rain_mask=rain_mask,
            emission_velocity=emission_velocity, velocity=velocity, velocity_medium=velocity_medium,
            sea_level=sea_level, layers=layers, materials=materials, layer_materials=layer_materials,
            deposit_material=deposit_material, layers_out=layers_out, change_map=change_map, paths=paths,
            path_count=path_count, path_stride=path_stride, threads=threads, band=band, channel=channel,
            parameter_values=parameter_values or {}, representation=representation, voxel_size=voxel_size,
            depth=depth, headroom=headroom, voxels=voxels, volume_out=volume_out, mesh=mesh,
            memory_budget=memory_budget, hits_per_voxel=hits_per_voxel, hits_threshold=hits_threshold,
            sdf=sdf, kinds=kinds, apply=apply,
        )
        prepared = plan(job)
        with progress_bar(prepared.iterations, "particle-erode", verbose - quiet) as advance:
            summary = run_job(prepared, on_iteration=lambda done: advance(f"iteration {done}"),
                              on_note=lambda text: say(text, verbose - quiet))
        say(summary, verbose - quiet, SUMMARY)


particle_erode.__doc__ = (
    "Erode a DEM with particles (003): each iteration emits particles (rain or a source) that "
    "fall, bounce and roll under gravity, buoyancy, Stokes drag and an optional medium velocity, "
    "detaching and depositing matter at every impact; the terrain is updated after each "
    "iteration (or at each impact: --apply per-impact). Works on a heightfield, a layered terrain (--layers, --materials), density or binary "
    "voxels (--representation; a block built from the DEM or --voxels) or an implicit terrain "
    "(--representation sdf, --sdf), whose top surface is OUTPUT; several kinds of particles may run "
    "together (--preset rain+wind+river, --kinds). Deterministic "
    "for a --seed whatever the threads. The JSON sidecar holds the mass budget (m³: detached, "
    "deposited, suspended, lost at edges, emitted) and counts.\n\nPresets (003 Table 1; R in "
    "cells of the DEM):\n\n" + _preset_lines()
)
