"""The plan of a `sandstone` job: options checked, OUT_DIR's files cleared, the scene or DEM
read, the simulation's parameters built, the provenance recorded, the run's checkpoint
(``OUT_DIR/state.npz``) named and, with ``--resume``, matched to this run; no particle is
sampled here."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from unerode_cli.errors import InputError
from unerode_cli.io.checkpoints import read_checkpoint_header
from unerode_cli.io.paths import OutputPlan
from unerode_cli.jobs.sandstone import meshes
from unerode_cli.jobs.sandstone.options import (
    ABLATIONS,
    COLOR_BY,
    DEFAULT_DT,
    DEFAULT_FRAMES,
    SNAPSHOT_FORMATS,
    TOP_FORMATS,
)
from unerode_cli.jobs.sandstone.source import Source
from unerode_cli.run.fingerprint import run_fingerprint
from unerode_cli.run.stepping import Checkpoints
from unerode_cli.sandstone.deflation import DeflationParams
from unerode_cli.sandstone.deposition import DepositionParams
from unerode_cli.sandstone.fluvial import FluvialParams
from unerode_cli.sandstone.mpm import MpmParams
from unerode_cli.sandstone.simulation import Processes, SimulationParams
from unerode_cli.sandstone.wind import WindParams

if TYPE_CHECKING:
    from unerode_cli.jobs.sandstone.job import SandstoneJob

PARTICLES_FILE, FRAMES_FILE, RUN_FILE, STATE_FILE, PREVIEW_FILE = (
    "particles.ply", "frames.csv", "run.json", "state.npz", "preview.png")
SNAPSHOTS = "snapshots"


@dataclass
class PreparedSandstone:
    """A checked job: the source, the simulation's parameters, OUT_DIR's files (``paths``: role →
    path, all cleared on the output plan), the provenance and the run's checkpoints (in
    ``state.npz``; with ``--resume``, one of this run)."""

    job: SandstoneJob
    source: Source
    params: SimulationParams
    paths: dict[str, Path]
    provenance: dict[str, Any]
    checkpoints: Checkpoints


def water_sources(job: SandstoneJob) -> tuple[tuple[float, float, float, float], ...]:
    """The ``--source`` points (x, y, z in m) and discharges (m³/y)."""
    return tuple((float(x), float(y), float(z), float(q)) for x, y, z, q in job.sources or ())


def check_options(job: SandstoneJob) -> None:
    """Refuse option values out of their range, before anything is read."""
    for option, value, low in (("--frames", job.frames, 1), ("--particles", job.particles, 1),
                               ("--threads", job.threads, 1), ("--substeps", job.substeps, 1),
                               ("--settle-substeps", job.settle_substeps, 1),
                               ("--snapshot-every", job.snapshot_every, 0),
                               ("--checkpoint-every", job.checkpoint_every, 1),
                               ("--max-steps", job.max_steps, 1),
                               ("--mesh-smoothing", job.mesh_smoothing, 0),
                               ("--mesh-every", job.mesh_every, 0)):
        if value is not None and value < low:
            raise InputError(f"{option} must be at least {low}, got {value}.")
    if job.dt is not None and not (math.isfinite(job.dt) and job.dt > 0):
        raise InputError(f"--dt must be a positive number of years, got {job.dt}.")
    if not 0 <= job.seed < 2**63:
        raise InputError(f"--seed must be an integer in [0, 2^63), got {job.seed}.")
    if job.color_by not in COLOR_BY:
        raise InputError(f"--color-by must be one of {', '.join(COLOR_BY)}, got '{job.color_by}'.")
    if job.top_format not in TOP_FORMATS:
        raise InputError(f"--top-format must be tif or exr, got '{job.top_format}'.")
    if job.snapshot_format not in SNAPSHOT_FORMATS:
        raise InputError(f"--snapshot-format must be ply or npz, got '{job.snapshot_format}'.")
    meshes.check_mesh_options(job)
    if job.resume and job.overwrite:
        raise InputError("--resume continues OUT_DIR's run and --overwrite starts it afresh: "
                         "give one of them.")


def with_run_settings(job: SandstoneJob, source: Source) -> SandstoneJob:
    """The job with ``--frames`` and ``--dt`` given: the options, else the scene's run settings
    (a preset's: what its landform needs), else DEFAULT_FRAMES and DEFAULT_DT."""
    run = source.run
    frames = job.frames if job.frames is not None else run.frames if run is not None else DEFAULT_FRAMES
    dt = job.dt if job.dt is not None else run.dt if run is not None else DEFAULT_DT
    return dataclasses.replace(job, frames=frames, dt=dt)


def output_paths(job: SandstoneJob) -> dict[str, Path]:
    """The files of OUT_DIR (and ``--mesh``, whose folder exists or is OUT_DIR), refused when one
    exists (without --overwrite or --resume); nothing is created."""
    out = job.out_dir
    if out.exists() and not out.is_dir():
        raise InputError(f"OUT_DIR {out} is a file, not a folder.")
    if not out.parent.exists():
        raise InputError(f"the folder of OUT_DIR {out} does not exist.")
    paths = {"particles": out / PARTICLES_FILE, "top": out / f"top.{job.top_format}",
             "preview": out / PREVIEW_FILE, "frames": out / FRAMES_FILE, "run": out / RUN_FILE,
             "state": out / STATE_FILE}
    if job.mesh is not None:
        if not (job.mesh.parent.exists() or mesh_in_out_dir(job)):
            raise InputError(f"the folder of --mesh {job.mesh} does not exist.")
        paths.update(meshes.final_mesh_paths(job))
    if not (job.overwrite or job.resume):
        for path in [*paths.values(), out / SNAPSHOTS, out / meshes.MESHES]:
            if path.exists():
                raise InputError(f"output {path} already exists; pass --overwrite to replace it "
                                 "(or --resume to continue its run).")
    return paths


def mesh_in_out_dir(job: SandstoneJob) -> bool:
    """Whether ``--mesh`` names a file directly in OUT_DIR (which the job creates)."""
    return job.mesh is not None and job.mesh.parent.resolve() == job.out_dir.resolve()


def snapshot_path(job: SandstoneJob, frame: int) -> Path:
    """The particles of ``frame`` written with ``--snapshot-every``, in ``--snapshot-format``."""
    return job.out_dir / SNAPSHOTS / f"frame_{frame:05d}.{job.snapshot_format}"


def clear_outputs(job: SandstoneJob, paths: dict[str, Path], outputs: OutputPlan) -> None:
    """Create OUT_DIR (and its snapshots folder) and clear every file the run may write on the
    output plan: never an input, never a folder. Existing files were refused (or allowed by
    --overwrite or --resume) by :func:`output_paths`."""
    job.out_dir.mkdir(exist_ok=True)
    if job.snapshot_every:
        (job.out_dir / SNAPSHOTS).mkdir(exist_ok=True)
    if job.mesh_every:
        (job.out_dir / meshes.MESHES).mkdir(exist_ok=True)
    every = job.snapshot_every
    snapshots = [snapshot_path(job, frame) for frame in range(every, job.frames + 1, every)] if every else []
    for path in [*paths.values(), *snapshots, *meshes.frame_mesh_paths(job)]:
        outputs.check_output(path, True, again=path == job.mesh)   # plan() may have cleared the mesh


def simulation_params(job: SandstoneJob, source: Source) -> SimulationParams:
    """The simulation's parameters: the options given, else the scene's (wind, water) or the
    rock's (cohesion, friction, deposit viability)."""
    wind, rock = source.wind, source.rock
    try:
        return SimulationParams(
            dt=job.dt,
            mpm=MpmParams(substeps=job.substeps, settle_substeps=job.settle_substeps,
                          tolerance=job.tolerance),
            wind=WindParams(azimuth=_given(job.wind_azimuth, wind.azimuth),
                            elevation=_given(job.wind_elevation, wind.elevation),
                            speed=_given(job.wind_speed, wind.speed),
                            cone_angle=wind.cone_angle, rays=wind.rays,
                            rose=() if job.wind_azimuth is not None else wind.rose_pairs(),
                            model=_given(job.wind_model, wind.model)),
            deflation=DeflationParams(alpha=job.alpha, cohesion=rock.cohesion, friction=rock.friction),
            deposition=DepositionParams(repose_angle=job.repose_angle,
                                        deposit_viability=rock.deposit_viability),
            fluvial=FluvialParams(precipitation=_given(job.precipitation, source.water.precipitation),
                                  sources=source.water.source_tuples() + water_sources(job)),
            processes=Processes(**{process: not getattr(job, flag) for flag, process in ABLATIONS.items()}))
    except ValueError as exc:
        raise InputError(f"{str(exc).rstrip('.')}.") from None


def _given(value: Any, default: Any) -> Any:
    return default if value is None else value


def provenance(job: SandstoneJob, source: Source, params: SimulationParams) -> dict[str, Any]:
    """The job's recorded options and what the plan derived: the source, its lattice (m), the
    layers, the rock and every process's parameters; the DEM's grid for an extruded DEM."""
    lattice = source.lattice
    record = {
        **job.provenance(), "scene": source.description, "particles_expected": source.expected,
        "lattice_spacing_m": lattice.spacing, "domain_low_m": lattice.low, "domain_size_m": lattice.size,
        "mpm_cell_m": lattice.mpm_grid().h, "layers": [asdict(layer) for layer in source.layers.layers],
        "deposit_layer": asdict(source.layers.deposit), "rock": asdict(source.rock),
        "mpm": asdict(params.mpm), "wind": asdict(params.wind), "deflation": asdict(params.deflation),
        "deposition": asdict(params.deposition), "fluvial": asdict(params.fluvial),
        "processes": asdict(params.processes),
    }
    if source.dem is not None:
        record["dem_transform"] = list(source.dem.transform)[:6]
        record["dem_crs_wkt"] = source.dem.crs_wkt
        record["coordinates"] = "x, y in m from the DEM's south-west corner; z in m"
    return record


def checkpoints(job: SandstoneJob, paths: dict[str, Path], scene_file: Path | None,
                provenance: dict[str, Any]) -> Checkpoints:
    """The run's checkpoints: ``state.npz`` in OUT_DIR (compressed), every ``--checkpoint-every``
    frames, named by the fingerprint of everything but the frame count (so that --resume may ask
    for more frames) and of the scene or DEM file's contents."""
    fields = {k: v for k, v in provenance.items() if k != "frames"}
    return Checkpoints(paths["state"], job.checkpoint_every, job.resume,
                       run_fingerprint(fields, [scene_file]), compressed=True)


def check_resume(job: SandstoneJob, checkpoints: Checkpoints) -> None:
    """Refuse a ``--resume`` whose ``state.npz`` is missing, unreadable, of a run with other
    parameters or another seed, or has done ``--frames`` already. Only the checkpoint's
    fingerprint and frame count are read (its particles are read when the run resumes)."""
    path = checkpoints.path
    assert path is not None
    if not path.is_file():
        raise InputError(f"--resume needs {path}, left by a stopped run or one with --snapshot-every; "
                         "there is none.")
    fingerprint, done = read_checkpoint_header(path)
    if fingerprint != checkpoints.fingerprint:
        raise InputError(f"the run in {job.out_dir} had other parameters or another seed; resume it with "
                         "the same scene and options (only --frames may change).")
    if done >= job.frames:
        raise InputError(f"the run in {job.out_dir} has already done {done} frames; ask for more with "
                         "--frames.")
