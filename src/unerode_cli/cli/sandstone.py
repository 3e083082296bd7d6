"""`unerode-cli sandstone`: erode a 3D sandstone rock of particles (002, Arenite)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from unerode_cli.cli.errors import reported_errors
from unerode_cli.cli.options import METRES, POSITIVE_YEARS, Overwrite, Quiet, Seed, Verbose
from unerode_cli.cli.parameter_options import with_parameter_options
from unerode_cli.cli.values import Number
from unerode_cli.sandstone.layers import LAYER_PARAMETERS, ROCK_PARAMETERS

LAYER_PANEL = "Layers (002 Eq. 2, 8, 12; Table 1): a value given replaces every layer's; 'default' is that of a layer that sets none"
ROCK_PANEL = "Rock (002 §4, Eq. 9; Table 2)"
RUN = "Run"
PROCESSES = "Processes and wind"
OUTPUTS = "Outputs"


@with_parameter_options({LAYER_PANEL: LAYER_PARAMETERS, ROCK_PANEL: ROCK_PARAMETERS})
def sandstone(
    scene: Annotated[str, typer.Argument(help="A scene YAML file, a preset (arch, hoodoo), or a DEM (.tif, .exr, any GDAL raster; needs --extrude).")],
    out_dir: Annotated[Path, typer.Argument(help="Output folder (created): particles.ply, top.tif|exr, preview.png, frames.csv, run.json.")],
    extrude: Annotated[float | None, typer.Option("--extrude", parser=METRES, help="With a DEM: the rock fills each column from this altitude BASE_M (m) up to the DEM's surface.", rich_help_panel=RUN)] = None,
    particles: Annotated[int | None, typer.Option("--particles", min=1, help="Approximate particle count (the sampling spacing and the grids follow; default: the scene's, presets: 002 Table 1's).", rich_help_panel=RUN)] = None,
    frames: Annotated[int, typer.Option("--frames", help="Frames to run (each: stress, normals, wind, fluvial, erosion, deposition).", rich_help_panel=RUN)] = 100,
    dt: Annotated[float, typer.Option("--dt", parser=POSITIVE_YEARS, help="Time step of a frame (years; 002 Table 2: 1000).", rich_help_panel=RUN)] = 1000.0,
    seed: Seed = 0,
    threads: Annotated[int | None, typer.Option("--threads", min=1, help="Numba threads (default: all cores); the result does not depend on it.", rich_help_panel=RUN)] = None,
    substeps: Annotated[int, typer.Option("--substeps", min=1, help="Most MLS-MPM substeps per frame (fewer when the stress has converged; the stress of a fast-changing rock lags with too few).", rich_help_panel=RUN)] = 10,
    settle_substeps: Annotated[int, typer.Option("--settle-substeps", min=1, help="Most MLS-MPM substeps of the first frame (the settling from the lithostatic guess).", rich_help_panel=RUN)] = 3000,
    tolerance: Annotated[float, typer.Option("--tolerance", parser=Number("", 0.0, above=True), help="The MPM has converged when the RMS grid speed is below this share of gH/c_p (dimensionless).", rich_help_panel=RUN)] = 2e-3,
    no_abrasion: Annotated[bool, typer.Option("--no-abrasion", help="Ablation: no wind abrasion (002 Eq. 8).", rich_help_panel=PROCESSES)] = False,
    no_deflation: Annotated[bool, typer.Option("--no-deflation", help="Ablation: no wind deflation (002 Eq. 12).", rich_help_panel=PROCESSES)] = False,
    no_deposition: Annotated[bool, typer.Option("--no-deposition", help="Ablation: eroded particles leave the domain (002 §7 off).", rich_help_panel=PROCESSES)] = False,
    no_stress: Annotated[bool, typer.Option("--no-stress", help="Ablation: no fabric interlocking (I = ∞, 002 Fig. 16).", rich_help_panel=PROCESSES)] = False,
    no_fluvial: Annotated[bool, typer.Option("--no-fluvial", help="Ablation: no fluvial erosion (002 Eq. 14, Fig. 14).", rich_help_panel=PROCESSES)] = False,
    precipitation: Annotated[float | None, typer.Option("--precipitation", parser=Number("m/y", 0.0), help="Precipitation p on the top of the domain (m/y; default: the scene's, 0.25). Fluvial erosion needs a layer with --k-t > 0.", rich_help_panel=PROCESSES)] = None,
    sources: Annotated[list[str] | None, typer.Option("--source", help="Water source X,Y,Z,Q: a point (m, inside the domain) and its discharge Q (m³/y); repeatable, added to the scene's.", rich_help_panel=PROCESSES)] = None,
    wind_azimuth: Annotated[float | None, typer.Option("--wind-azimuth", parser=Number("degrees", 0.0, 360.0), help="Direction the storm wind comes from, degrees clockwise from north (default: the scene's; 270 = from the west).", rich_help_panel=PROCESSES)] = None,
    wind_elevation: Annotated[float | None, typer.Option("--wind-elevation", parser=Number("degrees", -90.0, 90.0), help="Elevation of the direction the wind comes from (degrees above the horizon; default: the scene's, 0).", rich_help_panel=PROCESSES)] = None,
    wind_speed: Annotated[float | None, typer.Option("--wind-speed", parser=Number("m/s", 0.0), help="Free wind speed U of abrasion (m/s; default: the scene's, 10).", rich_help_panel=PROCESSES)] = None,
    alpha: Annotated[float, typer.Option("--alpha", parser=Number("Pa", 0.0, above=True), help="Rayleigh scale α of the normal drag of deflation (Pa; 002 Eq. 11-12 gives none).", rich_help_panel=PROCESSES)] = 1e6,
    repose_angle: Annotated[float, typer.Option("--repose-angle", parser=Number("degrees", 0.0, 89.9), help="Angle of repose of deposits (degrees, 002 §7).", rich_help_panel=PROCESSES)] = 33.0,
    color_by: Annotated[str, typer.Option("--color-by", help="Colour of preview.png: layer, stress (MPa) or viability.", rich_help_panel=OUTPUTS)] = "layer",
    top_format: Annotated[str, typer.Option("--top-format", help="Format of the top heightfield: tif (GeoTIFF) or exr.", rich_help_panel=OUTPUTS)] = "tif",
    snapshot_every: Annotated[int, typer.Option("--snapshot-every", min=0, help="Write the particles (snapshots/frame_NNNNN.ply) and the resumable state (state.npz) every this many frames; 0: never.", rich_help_panel=OUTPUTS)] = 0,
    mesh: Annotated[Path | None, typer.Option("--mesh", help="Also write the closed surface mesh of the final particles, coloured by layer: OUT.ply (binary) or OUT.obj (with vertex colours); needs scikit-image: pip install 'unerode-cli[mesh]'.", rich_help_panel=OUTPUTS)] = None,
    mesh_smoothing: Annotated[int, typer.Option("--mesh-smoothing", min=0, help="Taubin smoothing iterations of --mesh (they keep the volume; 0: the raw marching cubes).", rich_help_panel=OUTPUTS)] = 5,
    resume: Annotated[bool, typer.Option("--resume", help="Continue OUT_DIR's run from its state.npz up to --frames (same scene and options).", rich_help_panel=OUTPUTS)] = False,
    band: Annotated[int | None, typer.Option("--band", help="Band of a multi-band DEM (1-based).", rich_help_panel=RUN)] = None,
    channel: Annotated[str | None, typer.Option("--channel", help="EXR channel of the DEM (default: Y).", rich_help_panel=RUN)] = None,
    overwrite: Overwrite = False,
    verbose: Verbose = 0,
    quiet: Quiet = 0,
    parameter_values: dict[str, str | None] | None = None,
) -> None:
    with reported_errors(verbose - quiet):
        from unerode_cli.cli.common import SUMMARY, say
        from unerode_cli.cli.progress import progress_bar
        from unerode_cli.cli.values import Numbers
        from unerode_cli.errors import InputError
        from unerode_cli.jobs.sandstone import SandstoneJob, plan, run_job
        from unerode_cli.sandstone.simulation import Processes

        try:
            water_sources = tuple(Numbers("X,Y,Z,Q (m, m and m³/y)", 4).parse(text) for text in sources or ())
        except ValueError as exc:
            raise InputError(f"--source: {exc}.") from None
        job = SandstoneJob(
            scene=scene, out_dir=out_dir, extrude=extrude, particles=particles, frames=frames, dt=dt, seed=seed,
            threads=threads, substeps=substeps, settle_substeps=settle_substeps, tolerance=tolerance,
            processes=Processes(abrasion=not no_abrasion, deflation=not no_deflation,
                                deposition=not no_deposition, stress=not no_stress, fluvial=not no_fluvial),
            wind_azimuth=wind_azimuth, wind_elevation=wind_elevation, wind_speed=wind_speed, alpha=alpha,
            repose_angle=repose_angle, precipitation=precipitation, sources=water_sources,
            color_by=color_by, top_format=top_format,
            snapshot_every=snapshot_every, mesh=mesh, mesh_smoothing=mesh_smoothing, resume=resume,
            overwrite=overwrite, band=band, channel=channel,
            parameter_values=parameter_values or {},
        )
        prepared = plan(job)
        say(f"{prepared.source.description}: about {prepared.source.expected:,.0f} particles, lattice spacing "
            f"{prepared.source.lattice.spacing:.3g} m", verbose - quiet)
        with progress_bar(frames, "sandstone", verbose - quiet) as advance:
            summary = run_job(prepared, on_frame=lambda s: advance(
                f"{s.particles:,} particles, {s.eroded} eroded, {1.0 / max(sum(s.seconds.values()), 1e-9):.2g} frames/s"))
        say(summary, verbose - quiet, SUMMARY)


sandstone.__doc__ = (
    "Erode a 3D sandstone rock (002, Arenite): particles sampled in a scene (CSG of boxes, spheres "
    "and cylinders with sediment layers, painted regions and noise), a preset (arch, hoodoo) or a "
    "DEM extruded into a block; each frame computes the stress (MLS-MPM, corotated), switches the "
    "erodibility where the rock interlocks (compressive stress -tr σ above I), erodes the surface by "
    "wind abrasion and deflation and by the shear stress of the water routed over it in 3D (rain "
    "and sources), and deposits what eroded on stable cells. Deterministic for a "
    "--seed whatever the threads."
)
