"""Options of `particle-erode` (declared once: CLI, pipeline, Python API, provenance).

Provenance: options whose value the plan records in a derived form are not recorded as given
(``--particles`` as ``particles_per_iteration``, ``--spread`` as ``spread_m``,
``--emission-velocity`` as ``emission_velocity_m_s``, ``--source`` as ``source_points``, the
particle parameters as the values of each kind).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from unerode_cli.jobs.particle_erode import parsers
from unerode_cli.particles.parameters import PARAMETERS
from unerode_cli.run.common_options import (
    CHECKPOINT_EVERY,
    MAX_STEPS,
    OUTPUT,
    OUTPUT_PANEL,
    RASTER_OUTPUT,
    READING,
    RESUME,
    SEA_LEVEL,
    SEED,
    SOURCE,
)
from unerode_cli.run.declare import Opt, parameter_options
from unerode_cli.run.values import Number

PARAMETER_PANEL = ("Particle parameters (003 §3-4): a value given replaces the preset's; 'default' is the "
                   "value a preset does not set")
RUN, EMISSION, MEDIUM, TERRAIN = "Run", "Emission", "Medium", "Terrain"
VOXELS, LAYERED = "Voxels", "Layered terrain"
#: Memory a voxel run may take unless --memory-budget says otherwise (GiB).
DEFAULT_MEMORY_BUDGET_GIB = 4.0
#: Iterations between checkpoints unless --checkpoint-every says otherwise: the presets run 3 to
#: 100 iterations, so a long run is saved a few times and a short one (10) not at all, while a
#: voxel terrain's checkpoint (every voxel) is written seldom.
DEFAULT_CHECKPOINT_EVERY = 25

_RUN = (
    Opt("preset", str, None,
        "Preset of 003 Table 1: rain, meanders, river, landslide, coastal, wind, underwater, "
        "volcano, karst or tunnel (described above), or several joined by + (e.g. rain+wind+river: each kind "
        "of particles with its preset's count and values, 003 Fig. 8); every value can be overridden. "
        "Default: rain.", panel=RUN, parser=parsers.PRESET),
    Opt("kinds", Path, None,
        "YAML of the kinds of particles of the run, in order (each: preset, particles per "
        "iteration, velocity, parameters; optional iterations; see the README); instead of --preset.",
        role="input", panel=RUN, record="kinds_file"),
    Opt("particles", int, None, "Particles emitted per iteration (default: the preset's).", minimum=1,
        panel=RUN, record=False),
    Opt("iterations", int, None, "Iterations; the terrain is updated after each (at each impact with --apply "
        "per-impact; default: the preset's).", minimum=1, panel=RUN),
    SEED,
    Opt("threads", int, None, "Numba threads (default: all cores); the result does not depend on it.",
        minimum=1, panel=RUN, record=False),
    Opt("apply", str, "per-iteration", "When impacts alter the terrain: per-iteration (every particle of an "
        "iteration traced in parallel against the terrain as it stood before the iteration, then their "
        "impacts applied in order: fast, but many particles per iteration all settle in the same hollows and "
        "pile up there) or per-impact (each impact applied as it happens, 003 §3: a particle meets what it "
        "and every particle before it did, but the particles are traced one after the other, on one thread; "
        "heightfield, density and binary only). Both conserve mass and are deterministic.", panel=RUN),
)

_EMISSION = (
    Opt("emission", str, None, "rain (over the domain or --rain-mask) or source (--source); default: the "
        "preset's, source when --source is given.", panel=EMISSION, parser=parsers.EMISSION),
    Opt("sources", str, None, "Source point X,Y in the DEM's CRS units (repeat for the vertices of a line), "
        "or a GeoJSON/WKT line file; default: the highest cell.", flags=("--source",), kind="multiple",
        panel=EMISSION, record=False),
    Opt("spread", float, None, "Source particles start uniformly within this distance (m) of the point or "
        "line (default: the particle radius R).", parser=Number("m", 0.0), panel=EMISSION, record=False),
    Opt("rain_mask", Path, None, "Raster on the DEM's grid of rain weights (≥ 0, unitless): where rain "
        "particles start.", role="input", panel=EMISSION),
    Opt("emission_velocity", str, None, "Initial particle velocity VE,VN[,VU] (m/s, east, north, up; "
        "default 0).", parser=parsers.EMISSION_VELOCITY, panel=EMISSION, record=False),
)

_MEDIUM = (
    Opt("velocity", str, None, "Medium velocity field (003 Eq. 8): uniform:VE,VN[,VU] (m/s), "
        "sin[:AMPLITUDE,WAVELENGTH] (a northward AMPLITUDE·sin(2πx/WAVELENGTH), m/s and m: 003 Table 1 "
        "meanders; default 1 m/s and a quarter of the DEM's width), or a 2/3-band raster on the DEM's grid "
        "(east, north[, up] m/s). Default: still medium.", panel=MEDIUM),
    Opt("velocity_medium", str, None, "Where the velocity field acts: both, air (above --sea-level) or water "
        "(below); default: the preset's.", panel=MEDIUM, parser=parsers.MEDIUM),
    dataclasses.replace(SEA_LEVEL, help="Elevation (m) below which the medium is water (density rho_water, "
                        "viscosity mu_water); default: air everywhere.", panel=MEDIUM, record="sea_level_m"),
)

_TERRAIN = (
    Opt("representation", str, None, "Terrain representation (003 §4): heightfield, layers (--layers), "
        "density (density voxels, 003 Eq. 13), binary (binary voxels with hit counts, Eq. 14) or sdf (an "
        "implicit terrain: a signed distance function altered by metaballs, Eq. 11). Default: that of "
        "--voxels, sdf with --sdf, layers with --layers, else the preset's (heightfield; karst: binary, "
        "tunnel: density, meanders: sdf).", panel=TERRAIN, parser=parsers.REPRESENTATION),
    Opt("sdf", Path, None,
        "Implicit terrain: a YAML scene of primitives in the DEM's CRS (the DEM's surface, "
        "plane, box, sphere, capsule; union, difference; see the README) instead of the DEM's surface alone; "
        "the DEM gives the columns.", role="input", panel=TERRAIN, record="sdf_scene"),
)

_VOXELS = (
    Opt("voxel_size", float, None,
        "Voxels: size (m) of the block built from the DEM, or of the node cache of "
        "an implicit terrain (default: the DEM's cell size); preset radii are in voxels.",
        parser=Number("m", 0.0, above=True), panel=VOXELS),
    Opt("depth", float, None,
        "Voxels: the block reaches this far (m) below the DEM's lowest cell (default 10 "
        "voxels).", parser=Number("m", 0.0), panel=VOXELS),
    Opt("headroom", float, None, "Voxels: the block reaches this far (m) above the DEM's highest cell, room "
        "for deposits (default 10 voxels).", parser=Number("m", 0.0), panel=VOXELS),
    Opt("voxels", Path, None, "Voxels: read the volume from this .npz (arrays origin, voxel_size, density or "
        "solid + hits, optional material, material_names, valid, crs; see the README) instead of building a "
        "block from the DEM.", role="input", panel=VOXELS),
    Opt("volume_out", Path, None, "Voxels: write the altered volume (.npz, the --voxels format).",
        role="output", panel=VOXELS, record=False),
    Opt("mesh", Path, None,
        "Voxels: write the closed surface mesh of the altered ground (.glb, .obj with its .mtl, or "
        ".ply; m from its origin, materials by layer; Y-up in .glb and .obj; needs scikit-image, and "
        "trimesh for .glb).", role="output", panel=VOXELS,
        record=False),
    Opt("memory_budget", float, DEFAULT_MEMORY_BUDGET_GIB,
        "Voxels: refuse a volume whose run would need more "
        "memory than this (GiB).", parser=Number("GiB", 0.0, above=True), panel=VOXELS, record=False),
    Opt("hits_per_voxel", float, None, "Binary voxels: α of 003 Eq. 14, hits per voxel volume of matter a "
        "voxel receives (default 1000000: shares of a millionth of a voxel still count).",
        parser=Number("hits", 0.0, above=True), panel=VOXELS),
    Opt("hits_threshold", int, None, "Binary voxels: C, the hits at which a voxel flips (003 Eq. 14; default "
        "1000000, with the default α a voxel's worth of matter).", minimum=1, panel=VOXELS),
)

_LAYERED = (
    Opt("layers", Path, None, "Multi-band raster on the DEM's grid of layer thicknesses (m), bottom layer "
        "first (003 §4.2); the base of the stack is the DEM minus their sum.", role="input", panel=LAYERED),
    Opt("materials", Path, None, "Materials table (CSV: name, erodibility K_eps in Pa^-a, critical_stress "
        "tau_c in Pa), or for voxels a YAML of 3D material layers (materials, horizons by elevation, "
        "deposit, eroded rules; see the README); replaces --k-eps and --tau-c.", role="input",
        panel=LAYERED),
    Opt("layer_materials", str, None, "Material name of each band, bottom first, comma-separated (default: "
        "the band descriptions, else the table's rows in order).", panel=LAYERED),
    Opt("deposit_material", str, None, "Material that deposits become (default: the top layer's or "
        "horizon's).", panel=LAYERED),
    Opt("layers_out", Path, None, "Output layers (GeoTIFF, thicknesses in m, bottom first, the deposit layer "
        "on top, band descriptions = materials); default OUTPUT_layers.tif.", role="output", panel=LAYERED,
        record=False),
)

_OUTPUTS = (
    Opt("change_map", Path, None, "Write the elevation change Δh (m): < 0 erosion, > 0 deposition.",
        role="output", panel=OUTPUT_PANEL, record=False),
    Opt("paths", Path, None,
        "Write a GeoJSON of sampled particle paths: LineStrings x, y (DEM's CRS), z (m), "
        "with id, fate and times (s).", role="output", panel=OUTPUT_PANEL, record=False),
    Opt("path_count", int, 100, "Paths sampled for --paths, evenly over the run's particles.", minimum=1,
        panel=OUTPUT_PANEL, record=False),
    Opt("path_stride", int, 4, "Record a path point every this many time steps (and at death).", minimum=1,
        panel=OUTPUT_PANEL, record=False),
)

#: The checkpoint options (``common_options.CHECKPOINTS``), counted in iterations.
_CHECKPOINTS = (
    dataclasses.replace(CHECKPOINT_EVERY, default=DEFAULT_CHECKPOINT_EVERY, help="Write a checkpoint "
                        "(.OUT.checkpoint.npz beside OUT) every this many iterations."),
    RESUME,
    dataclasses.replace(MAX_STEPS, help="Stop after this many iterations of this invocation (checkpointed; "
                        "continue with --resume)."),
)

OPTIONS = (
    SOURCE,
    OUTPUT,
    *_RUN,
    *_EMISSION,
    *_MEDIUM,
    *_TERRAIN,
    *_VOXELS,
    *_LAYERED,
    *_OUTPUTS,
    *_CHECKPOINTS,
    *READING,
    *RASTER_OUTPUT,
) + parameter_options({PARAMETER_PANEL: PARAMETERS})
