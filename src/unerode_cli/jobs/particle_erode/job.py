"""The `particle-erode` job (003): plan (check everything, read inputs, build the terrain, the
emission and the medium), run the particles, write the outputs.

Inputs: the DEM is the ground surface (m). A layered terrain (003 §4.2) adds a multi-band
raster of layer thicknesses (m, bottom layer first) and a materials table; the base of the
stack is the surface minus the total thickness. A voxel terrain (003 §4.4: density or binary
voxels) is a block built from the DEM (``volume.dem_block``: columns of about ``--voxel-size``
over its extent, from ``--depth`` below its lowest cell to ``--headroom`` above its highest, CRS
and origin kept), with 3D material layers from a YAML of horizons, or a volume read from
``--voxels`` (an .npz, ``io.voxel_files``). An implicit terrain (003 §4.3: a signed distance
function altered by metaballs) has the DEM's surface, or the scene of ``--sdf``
(``io.sdf_scene``), as its base, and its cache of nodes on the block the DEM would give
(``terrains``). Several kinds of particles run together (003 Fig. 8) from ``--preset A+B+…``
or ``--kinds`` (``kinds``). The option texts are parsed in ``parsers``.

Outputs (``writing``): the new surface (a DEM like the input; on voxels and implicit terrains
the highest ground surface of each column, on the volume's columns), optionally the change map
Δh (m), the layers (thicknesses, the deposit layer on top) or the altered volume and its surface
mesh, and a GeoJSON of sampled particle paths. The JSON sidecar holds the mass budget (m³) and
the particle counts.

Mass budget (``particles.ParticleBudget``): emitted + detached − deposited − suspended − lost
= 0 up to rounding, and the terrain's volume changes by deposited − detached. ``emitted`` is
matter added by design (the particles' ``initial_load``: the volcano preset) and
``suspended`` matter removed by design (``keep_suspended``: the coastal preset's corrosion);
for the other presets both are 0 and detached = deposited + lost.

The iterations run through the shared stepping loop (``run.stepping``), one step each, on
``particles.simulate.ParticleIterations``: every ``--checkpoint-every`` iterations the run's
state (the terrain's arrays, the budget sums and counts, the sampled paths) is saved to
``.OUT.checkpoint.npz`` beside OUT. After ``--max-steps`` iterations of an invocation, or when
``Progress.cancelled`` says so after an iteration, the run stops with a checkpoint and writes
nothing else; a Ctrl-C stops it before the next batch of particles (``interrupts``: never inside
numba's dispatcher), keeping the checkpoint written last. ``--resume`` continues a stopped run, bit
for bit the run never stopped (a particle's random numbers come from its own stream keyed by
seed, iteration and index). A finished run removes its checkpoint.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.checkpoints import check_checkpoint, checkpoint_path
from unerode_cli.io.mesh_files import mesh_sidecars
from unerode_cli.io.particle_kinds import KindSpec
from unerode_cli.io.paths import OutputPlan, check_output
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.particle_erode import checks, kinds, parsers, terrains, writing
from unerode_cli.jobs.particle_erode.interrupts import deferred_interrupt
from unerode_cli.jobs.particle_erode.options import OPTIONS
from unerode_cli.particles import (
    IMPLICIT_REPRESENTATIONS,
    VOXEL_REPRESENTATIONS,
    HeightfieldTerrain,
    LayeredTerrain,
    ParticleKind,
    ParticleRun,
    Preset,
    get_preset,
)
from unerode_cli.particles import Terrain as ParticleTerrain
from unerode_cli.particles.simulate import ParticleIterations
from unerode_cli.run.common_options import input_georef
from unerode_cli.run.declare import declared
from unerode_cli.run.divergence import DivergenceGuard
from unerode_cli.run.fingerprint import run_fingerprint
from unerode_cli.run.job import Job, Progress
from unerode_cli.run.outputs import Outputs, check_png, check_raster
from unerode_cli.run.stepping import NO_CHECKPOINTS, Checkpoints, StepInfo, Stepped, step_through


@declared("particle-erode", OPTIONS)
class ParticleJob(Job):
    """Erode a DEM with particles (003). Texts are parsed when the job plans; None = the
    preset's value. ``preset`` may name several presets joined by "+" (None: rain, or the
    kinds of ``kinds``). Units are in the declarations (``options``)."""

    def plan(self, outputs: OutputPlan) -> PreparedParticleJob:
        return plan(self, outputs)

    def run(self, planned: PreparedParticleJob, progress: Progress) -> tuple[PreparedParticleJob,
                                                                               ParticleResult]:
        with deferred_interrupt() as deferred:
            result = run_particles(planned, progress, deferred.check)
            deferred.check()
        return planned, result

    def write(self, result: tuple[PreparedParticleJob, ParticleResult], outputs: OutputPlan) -> str:
        return writing.write_all(*result)


@dataclass
class PreparedParticleJob:
    """A checked job: inputs read, terrain and kinds of particles (parameters, emission and
    medium) built, every output path cleared; ``surface`` is the terrain's top heightfield
    before the run (the DEM, or a 3D terrain's on its columns), ``provenance`` what the
    outputs' history records, ``notes`` what the user is told when the run starts,
    ``checkpoints`` where and how often the run is checkpointed."""

    job: ParticleJob
    dem: Terrain
    terrain: ParticleTerrain
    kinds: tuple[ParticleKind, ...]
    iterations: int
    outputs: Outputs
    layers_out: Path | None
    provenance: dict[str, Any]
    notes: list[str]
    surface: Terrain
    volume: terrains.VoxelSetup | None = None
    checkpoints: Checkpoints = NO_CHECKPOINTS


@dataclass
class ParticleResult:
    """The run (``particles.ParticleRun``), its wall time (s, over every invocation), its
    statistics for the sidecar and how the loop ended (``stepped.finished`` False: stopped by
    --max-steps or a cancel)."""

    run: ParticleRun
    seconds: float
    statistics: dict[str, Any]
    stepped: Stepped


def _inputs(job: ParticleJob, specs: list[KindSpec]) -> tuple[Path, ...]:
    """Every file the job reads: the DEM, the terrain's, emission's and medium's files."""
    named = (job.source, job.layers, job.materials, job.rain_mask, job.voxels, job.sdf, job.kinds,
             parsers.source_file(job.sources or ()))
    return tuple(p for p in named if p is not None) + tuple(kinds.velocity_rasters(job, specs))


def _clear_outputs(job: ParticleJob, inputs: tuple[Path, ...]) -> tuple[Outputs, Path | None]:
    """Clear every output before any work: the surface, change map and layers (rasters with
    sidecars), previews, paths, volume and mesh; returns the surface's outputs and the layers'
    path (None without --layers)."""
    outputs = Outputs.from_cli(job.output, job.dtype, job.cog, job.co, job.overwrite, job.preview)
    outputs.check(*inputs)
    layers_out = None
    if job.layers is not None:
        layers_out = job.layers_out or writing.default_layers_path(outputs.path)
        if layers_out.suffix.lower() not in (".tif", ".tiff"):
            raise InputError(f"the layers output must be a GeoTIFF (.tif), got {layers_out.name}.")
    rasters = [p for p in (job.change_map, layers_out) if p is not None]
    pngs = [writing.change_preview_path(job.change_map)] if job.change_map and outputs.preview else []
    files = [p for p in (job.paths, job.volume_out, job.mesh) if p is not None]
    files += list(mesh_sidecars(job.mesh)) if job.mesh is not None else []
    extra = [*rasters, *pngs, *files]
    if len(set(map(Path.resolve, [outputs.path, *extra]))) != len(extra) + 1:
        raise InputError("two outputs have the same path.")
    for path in rasters:
        check_raster(path, outputs.options, outputs.overwrite, inputs)
    for path in pngs:
        check_png(path, outputs.overwrite, inputs)
    for path in files:
        check_output(path, outputs.overwrite, inputs)
    return outputs, layers_out


def plan(job: ParticleJob, plan_outputs: OutputPlan | None = None) -> PreparedParticleJob:
    """Check the whole job before any work (options, outputs, inputs, parameters) and build
    the terrain and the kinds of particles."""
    specs, file_iterations = kinds.kind_specs(job)
    presets = [get_preset(spec.preset) for spec in specs]
    representation = checks.representation(job, presets[0])
    checks.check_terrain_options(job, representation)
    checks.check_apply(job, representation)
    inputs = _inputs(job, specs)
    if plan_outputs is not None:
        for path in inputs:
            plan_outputs.read(path)
    check_checkpoint(job.output, job.resume, job.overwrite, inputs)
    outputs, layers_out = _clear_outputs(job, inputs)
    checks.check_counts(job)
    dem = read_terrain(job.source, band=job.band, channel=job.channel, georef=input_georef(job))
    dem.check_valid(job.source)
    outputs.check_source(dem, job.source)
    notes: list[str] = []
    volume = None
    if representation in VOXEL_REPRESENTATIONS:
        volume = terrains.voxel_setup(job, dem, representation, notes)
    elif representation in IMPLICIT_REPRESENTATIONS:
        volume = terrains.sdf_setup(job, dem)
    surface = dem if volume is None else volume.surface
    several = len(specs) > 1
    built = tuple(kinds.particle_kind(job, p, spec, surface, notes, several)
                  for p, spec in zip(presets, specs, strict=True))
    terrain: ParticleTerrain
    if volume is not None:
        terrain = volume.terrain
    elif representation == "layers":
        terrain = terrains.layered_terrain(job, dem, notes)
    else:
        with checks.bad_input():
            terrain = HeightfieldTerrain(np.nan_to_num(dem.elevation), surface.grid)
    with checks.bad_input():
        for kind in built:
            for part in (kind.params, kind.emission, kind.velocity):
                if part is not None:
                    part.validate(surface.grid)
    iterations = job.iterations or file_iterations or max(p.iterations for p in presets)
    provenance = _provenance(job, presets, specs, built, representation, iterations, surface, terrain, volume)
    sampling = {"sampled_paths": job.path_count if job.paths is not None else 0,
                "path_stride": job.path_stride}
    checkpoints = Checkpoints(checkpoint_path(job.output), job.checkpoint_every, job.resume,
                              run_fingerprint({**provenance, **sampling}, inputs))
    return PreparedParticleJob(job, dem, terrain, built, iterations, outputs, layers_out, provenance, notes,
                               surface, volume, checkpoints)


def _provenance(job: ParticleJob, presets: list[Preset], specs: list[KindSpec],
                built: tuple[ParticleKind, ...], representation: str, iterations: int, surface: Terrain,
                terrain: ParticleTerrain, volume: terrains.VoxelSetup | None) -> dict[str, Any]:
    """What the outputs' history records: the job's recorded options, then what the plan
    derived from them (presets, representation, particles and iterations, each kind's
    emission, medium and parameters, the layers' materials, the volume's voxels)."""
    provenance = {
        **job.provenance(), "preset": "+".join(p.name for p in presets), "representation": representation,
        "particles_per_iteration": sum(kind.emission.count for kind in built), "iterations": iterations,
    }
    described = [kinds.kind_provenance(job, p, spec, kind, surface)
                 for p, spec, kind in zip(presets, specs, built, strict=True)]
    if len(described) > 1:
        provenance["kinds"] = described
    else:
        provenance.update(described[0])
    if isinstance(terrain, LayeredTerrain):
        provenance["layer_materials"] = [terrain.materials[m].name for m in terrain.layer_material]
        provenance["deposit_material"] = terrain.materials[terrain.deposit_material].name
    if volume is not None:
        provenance.update(terrains.volume_provenance(volume))
    return provenance


class ParticleSteps:
    """The iterations of a run as the stepping loop drives them (``run.stepping.Stepper``):
    ``ParticleIterations``' state, and the wall time (s) of the invocations before this one."""

    def __init__(self, prepared: PreparedParticleJob,
                 between_batches: Callable[[], None] | None = None) -> None:
        job = prepared.job
        self.iterations = ParticleIterations(
            prepared.terrain, prepared.kinds, iterations=prepared.iterations, seed=job.seed,
            sea_level=job.sea_level, paths=job.path_count if job.paths is not None else 0,
            path_stride=job.path_stride, apply=job.apply, between_batches=between_batches)
        self.seconds_before = 0.0
        self.start = time.perf_counter()

    def step(self, k: int) -> StepInfo:
        assert k == self.iterations.done
        return StepInfo(f"iteration {self.iterations.iterate()}")

    def seconds(self) -> float:
        """Wall time (s) of the run over every invocation so far."""
        return self.seconds_before + time.perf_counter() - self.start

    def state(self) -> dict[str, Any]:
        return {**self.iterations.state(), "wall_time_s": self.seconds()}

    def restore(self, state: dict[str, Any]) -> None:
        self.iterations.restore(state)
        self.seconds_before = float(state["wall_time_s"])


def run_particles(prepared: PreparedParticleJob, progress: Progress,
                  between_batches: Callable[[], None] | None = None) -> ParticleResult:
    """The iterations of the run, one step each of the shared stepping loop (checkpoints,
    resume, --max-steps, cancel); the result is checked for a runaway surface and its
    statistics are computed. ``between_batches`` is called before each batch of particles
    (``ParticleIterations``): it raises ``KeyboardInterrupt`` after a Ctrl-C."""
    import numba

    job, surface = prepared.job, prepared.surface
    guard = DivergenceGuard(surface.elevation, hint="lower the particle count or the erosion rates")
    for note in prepared.notes:
        progress.note(note)
    if job.threads is not None:
        numba.set_num_threads(min(job.threads, numba.config.NUMBA_NUM_THREADS))
    steps = ParticleSteps(prepared, between_batches)
    stepped = step_through(steps, prepared.iterations, progress, job.COMMAND, prepared.checkpoints,
                           job.max_steps)
    result = steps.iterations.result()
    seconds = steps.seconds()
    progress.finish()
    guard.check(result.elevation, 0.0, f"after {result.iterations} iterations")
    return ParticleResult(result, seconds, writing.statistics(result, surface, seconds, prepared.terrain),
                          stepped)
