"""Options of `sandstone` (declared once: CLI, pipeline, Python API, provenance).

The defaults of the stress solver (``--substeps`` 10, ``--settle-substeps`` 3000,
``--tolerance`` 2e-3), of deflation (``--alpha`` 1e6 Pa), deposition (``--repose-angle`` 33°)
and of the mesh (``--mesh-smoothing`` 5) are those of ``MpmParams``, ``DeflationParams``,
``DepositionParams`` and ``volume.particle_surface.SMOOTHING``, written out here because those
modules import numba or scikit-image, which ``--help`` must not load.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from unerode_cli.run.common_options import (
    BAND,
    CHANNEL,
    CHECKPOINT_EVERY,
    CHECKPOINT_PANEL,
    GEOREF,
    MAX_STEPS,
    METRES,
    OVERWRITE,
    POSITIVE_YEARS,
    SEED,
)
from unerode_cli.run.declare import Opt, parameter_options
from unerode_cli.run.values import Number, Numbers
from unerode_cli.sandstone.layers import LAYER_PARAMETERS, ROCK_PARAMETERS

#: ``--frames`` and ``--dt`` (years) of a scene without ``run`` settings.
DEFAULT_FRAMES, DEFAULT_DT = 100, 1000.0

LAYER_PANEL = ("Layers (002 Eq. 2, 8, 12; Table 1): a value given replaces every layer's; 'default' is "
               "that of a layer that sets none")
ROCK_PANEL = "Rock (002 §4, Eq. 9; Table 2)"
RUN = "Run"
PROCESSES = "Processes and wind"
OUTPUTS = "Outputs"

COLOR_BY = ("layer", "stress", "viability")
#: Up axes of the mesh files (``io.mesh_files.UP_AXES``, which imports numpy: written out here).
UP_AXES = ("y", "z")
#: The presets of ``sandstone.presets.PRESETS`` (named here: that module loads the scene parser,
#: which ``--help`` need not; a test keeps the two equal).
PRESET_NAMES = ("arch", "hoodoo", "arcade", "alcove", "butte", "canyon", "cave")
TOP_FORMATS = ("tif", "exr")
SNAPSHOT_FORMATS = ("ply", "npz")
#: The ablations of 002 §8.4: field of the flag → process it turns off.
ABLATIONS = {"no_abrasion": "abrasion", "no_deflation": "deflation", "no_deposition": "deposition",
             "no_stress": "stress", "no_fluvial": "fluvial"}


def _ablation(name: str, help: str) -> Opt:
    return Opt(name, bool, False, help, kind="flag", panel=PROCESSES, record=False)


OPTIONS = (
    Opt("scene", str, help=f"A scene YAML file, a preset ({', '.join(PRESET_NAMES)}), or a DEM (.tif, .exr, "
        "any GDAL raster; needs --extrude).", argument=True, required=True, record=False),
    Opt("out_dir", Path, help="Output folder (created): particles.ply, top.tif|exr, preview.png, frames.csv, "
        "run.json.", argument=True, required=True, role="output", record=False),
    Opt("extrude", float, None, "With a DEM: the rock fills each column from this altitude BASE_M (m) up to "
        "the DEM's surface.", parser=METRES, panel=RUN),
    Opt("particles", int, None, "Approximate particle count (the sampling spacing and the grids follow; "
        "default: the scene's, presets: 002 Table 1's).", minimum=1, panel=RUN, record="particles_requested"),
    Opt("frames", int, None, "Frames to run (each: stress, normals, wind, fluvial, erosion, deposition; "
        f"default: the scene's run.frames, presets: what their landform needs, else {DEFAULT_FRAMES}).",
        panel=RUN),
    Opt("dt", float, None, "Time step of a frame (years; default: the scene's run.dt, presets: what "
        f"their landform needs, else 002 Table 2's {DEFAULT_DT:g}).", parser=POSITIVE_YEARS,
        panel=RUN, record="dt_years"),
    SEED,
    Opt("threads", int, None, "Numba threads (default: all cores); the result does not depend on it.",
        minimum=1, panel=RUN, record=False),
    Opt("substeps", int, 10, "Most MLS-MPM substeps per frame (fewer when the stress has converged; the "
        "stress of a fast-changing rock lags with too few).", minimum=1, panel=RUN, record=False),
    Opt("settle_substeps", int, 3000, "Most MLS-MPM substeps of the first frame (the settling from the "
        "lithostatic guess).", minimum=1, panel=RUN, record=False),
    Opt("tolerance", float, 2e-3, "The MPM has converged when the RMS grid speed is below this share of "
        "gH/c_p (dimensionless).", parser=Number("", 0.0, above=True), panel=RUN, record=False),
    _ablation("no_abrasion", "Ablation: no wind abrasion (002 Eq. 8)."),
    _ablation("no_deflation", "Ablation: no wind deflation (002 Eq. 12)."),
    _ablation("no_deposition", "Ablation: eroded particles leave the domain (002 §7 off)."),
    _ablation("no_stress", "Ablation: no fabric interlocking (I = ∞, 002 Fig. 16)."),
    _ablation("no_fluvial", "Ablation: no fluvial erosion (002 Eq. 14, Fig. 14)."),
    Opt("precipitation", float, None, "Precipitation p on the top of the domain (m/y; default: the scene's, "
        "0.25). Fluvial erosion needs a layer with --k-t > 0.", parser=Number("m/y", 0.0), panel=PROCESSES,
        record=False),
    Opt("sources", str, None, "Water source X,Y,Z,Q: a point (m, inside the domain) and its discharge Q "
        "(m³/y); repeatable, added to the scene's.", flags=("--source",), kind="multiple",
        parser=Numbers("X,Y,Z,Q (m, m and m³/y)", 4), panel=PROCESSES, record=False),
    Opt("wind_azimuth", float, None, "Direction the storm wind comes from, degrees clockwise from north "
        "(default: the scene's; 270 = from the west).", parser=Number("degrees", 0.0, 360.0),
        panel=PROCESSES, record=False),
    Opt("wind_elevation", float, None, "Elevation of the direction the wind comes from (degrees above the "
        "horizon; default: the scene's, 0).", parser=Number("degrees", -90.0, 90.0), panel=PROCESSES,
        record=False),
    Opt("wind_model", str, None, "How abrasion sees the wind: rays (exposure by rays cast upwind) or flow "
        "(the local wind of a lattice Boltzmann flow around the rock: speed-up at edges, wakes, "
        "recirculation; slower). Default: the scene's, rays.", choices=("rays", "flow"), panel=PROCESSES,
        record=False),
    Opt("wind_speed", float, None, "Free wind speed U of abrasion (m/s; default: the scene's, 10).",
        parser=Number("m/s", 0.0), panel=PROCESSES, record=False),
    Opt("alpha", float, 1e6, "Rayleigh scale α of the normal drag of deflation (Pa; 002 Eq. 11-12 gives "
        "none).", parser=Number("Pa", 0.0, above=True), panel=PROCESSES, record=False),
    Opt("repose_angle", float, 33.0, "Angle of repose of deposits (degrees, 002 §7).",
        parser=Number("degrees", 0.0, 89.9), panel=PROCESSES, record=False),
    Opt("color_by", str, "layer", "Colour of preview.png: layer, stress (MPa) or viability.",
        choices=COLOR_BY, panel=OUTPUTS, record=False),
    Opt("top_format", str, "tif", "Format of the top heightfield: tif (GeoTIFF) or exr.", choices=TOP_FORMATS,
        panel=OUTPUTS, record=False),
    Opt("snapshot_every", int, 0, "Write the particles (snapshots/frame_NNNNN.ply) every this many frames, "
        "and keep the run's final state (state.npz; also when a --resume finishes it), so that --resume "
        "with more --frames extends it; 0: never.", minimum=0, panel=OUTPUTS, record=False),
    Opt("snapshot_format", str, "ply", "Format of the snapshots: ply (binary, as particles.ply: for Houdini, "
        "Blender, MeshLab) or npz (the same columns as a compressed NumPy archive, frame_NNNNN.npz: "
        "about a quarter of the size, read by unerode_cli.io.particle_ply.read_particle_ply).",
        choices=SNAPSHOT_FORMATS, panel=OUTPUTS, record=False),
    Opt("mesh", Path, None, "Also write the closed surface mesh of the final particles, one material per "
        "layer, UVs by box projection: OUT.glb (glTF 2.0, per-vertex _STRESS, _VIABILITY, _LAYER), "
        "OUT.obj (with OUT.mtl) or OUT.ply; needs scikit-image (and trimesh for .glb): pip install "
        "'unerode-cli[mesh]'.", role="output", panel=OUTPUTS, record=False),
    Opt("mesh_cell", float, None, "Node spacing of the --mesh surface (m; default: the particle spacing): "
        "smaller for finer meshes, larger for lighter ones. Sheets and rods one particle thick are kept at "
        "least a particle (or a cell, when coarser) thick.",
        parser=Number("m", 0.0, above=True), panel=OUTPUTS, record=False),
    Opt("mesh_every", int, 0, "Also write the mesh of every this many frames, OUT_DIR/meshes/frame_NNNNN "
        "with --mesh's extension (.glb without --mesh), for animations; 0: never.", minimum=0,
        panel=OUTPUTS, record=False),
    Opt("up", str, "y", "Up axis of .glb and .obj meshes: y (what Blender, Houdini, Unreal and Godot import "
        "upright; x east, y up, z south) or z (the particles' x east, y north, z up). PLY is always z-up.",
        choices=UP_AXES, panel=OUTPUTS, record=False),
    Opt("mesh_smoothing", int, 5, "Taubin smoothing iterations of --mesh (they keep the volume; 0: the raw "
        "marching cubes).", minimum=0, panel=OUTPUTS, record=False),
    dataclasses.replace(CHECKPOINT_EVERY, help="Write the run's state (OUT_DIR/state.npz, the checkpoint) "
                        "every this many frames."),
    Opt("resume", bool, False, "Continue OUT_DIR's run from its state.npz (left by a stopped run, or by "
        "one with --snapshot-every) up to --frames (same scene and options).", kind="flag",
        panel=CHECKPOINT_PANEL, record=False),
    dataclasses.replace(MAX_STEPS, help="Stop after this many frames of this invocation (state.npz "
                        "checkpointed, the outputs of the frames done written; continue with --resume)."),
    dataclasses.replace(BAND, help="Band of a multi-band DEM (1-based).", panel=RUN),
    dataclasses.replace(CHANNEL, help="EXR channel of the DEM (default: Y).", panel=RUN),
    *GEOREF,
    OVERWRITE,
) + parameter_options({LAYER_PANEL: LAYER_PARAMETERS, ROCK_PANEL: ROCK_PARAMETERS})
