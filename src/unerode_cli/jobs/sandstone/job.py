"""The `sandstone` job (002 Arenite): plan (check everything, read the scene or DEM, size the
particles and refuse what would not fit in memory), run the frames, write OUT_DIR.

Outputs in OUT_DIR: ``particles.ply`` (binary; x y z, nx ny nz, viability, stress in MPa (−tr σ,
compression positive), erodibility E in 1/y, layer, surface, deposit, interlocked, vegetation),
``top.tif`` or ``top.exr`` (the top heightfield; a DEM's grid and CRS when extruded),
``preview.png``, ``frames.csv`` (one row per frame), ``run.json`` (parameters, seed, versions,
totals), and with ``--snapshot-every N`` the particles every N frames in ``snapshots/`` plus
``state.npz``, the state a ``--resume`` continues from. ``--mesh OUT.ply|OUT.obj`` adds the
closed surface mesh of the final particles, coloured by layer (its counts and enclosed volume go
to ``run.json``).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from typing import Any

from unerode_cli.errors import InputError
from unerode_cli.io.paths import OutputPlan
from unerode_cli.jobs.sandstone import planning
from unerode_cli.jobs.sandstone.files import COMMAND, row, write_outputs, write_snapshot, write_state
from unerode_cli.jobs.sandstone.options import OPTIONS
from unerode_cli.jobs.sandstone.planning import PreparedSandstone
from unerode_cli.jobs.sandstone.source import check_memory, check_sources, read_source, scene_path
from unerode_cli.run.declare import declared
from unerode_cli.run.job import Job, Progress
from unerode_cli.sandstone.particles import Particles
from unerode_cli.sandstone.simulation import Simulation


@declared(COMMAND, OPTIONS)
class SandstoneJob(Job):
    """Erode a 3D sandstone rock of particles. ``scene``: a scene YAML path, a preset name or a
    DEM path (with ``extrude``, the base altitude in m); ``dt`` years; wind azimuth and elevation
    in degrees, speed in m/s; ``alpha`` Pa; ``repose_angle`` degrees; ``precipitation`` m/y;
    ``sources`` water sources (x, y, z in m, Q in m³/y) added to the scene's; None = the scene's
    or the default."""

    def plan(self, outputs: OutputPlan) -> PreparedSandstone:
        """Check the whole job before any work: options, OUT_DIR, the scene or DEM, parameters,
        whether the particles fit in memory (estimated, before sampling) and, with --resume, the
        state it continues; then create OUT_DIR and clear its files."""
        planning.check_options(self)
        scene_file = scene_path(self.scene)
        if scene_file is not None:
            outputs.read(scene_file)
        paths = planning.output_paths(self)
        if self.mesh is not None:
            outputs.check_output(self.mesh, True)
        source = read_source(self.scene, self.particles, self.extrude, self.band, self.channel,
                             self.parameter_values())
        check_sources(planning.water_sources(self), source)
        params = planning.simulation_params(self, source)
        check_memory(source)
        provenance = planning.provenance(self, source, params)
        state = planning.resume_state(self, paths, provenance) if self.resume else None
        planning.clear_outputs(self, paths, outputs)
        return PreparedSandstone(self, source, params, paths, provenance, state)

    def run(self, planned: PreparedSandstone, progress: Progress) -> SandstoneResult:
        return run_frames(planned, progress)

    def write(self, result: SandstoneResult, outputs: OutputPlan) -> str:
        write_outputs(result.prepared, result.simulation, result.rows, result.seconds, result.sampled)
        return summary(result)


@dataclass
class SandstoneResult:
    """The simulation after its last frame, the rows of ``frames.csv``, the wall time of the run
    and of its sampling (s), and whether it stopped before ``--frames`` (cancelled)."""

    prepared: PreparedSandstone
    simulation: Simulation
    rows: list[dict[str, Any]]
    seconds: float
    sampled: float
    stopped: bool


def start_simulation(prepared: PreparedSandstone) -> tuple[Simulation, list[dict[str, Any]]]:
    """The simulation at its first frame (particles sampled with the job's seed), or at the
    frame of the resumed state with its rows of ``frames.csv``."""
    job, source, state = prepared.job, prepared.source, prepared.resume_state
    if state is None:
        particles = source.build(job.seed)
        if len(particles) == 0:
            raise InputError(f"{source.description} has no particle inside the domain.")
        return Simulation(particles, source.layers, source.rock, source.lattice, prepared.params,
                          job.seed), []
    particles = Particles.from_arrays({k[len("particle_"):]: v for k, v in state.items()
                                       if k.startswith("particle_")})
    simulation = Simulation(particles, source.layers, source.rock, source.lattice, prepared.params,
                            job.seed, int(state["frame"]))
    simulation.changes = state["changes"]
    return simulation, json.loads(str(state["rows"]))


def run_frames(prepared: PreparedSandstone, progress: Progress) -> SandstoneResult:
    """Sample (or resume) and run the frames up to ``--frames``, writing a snapshot and the
    resumable state every ``--snapshot-every`` frames. When ``progress`` says cancelled, the
    run stops after the current frame (with --snapshot-every, its state is written so that
    --resume continues it)."""
    import numba

    job, source = prepared.job, prepared.source
    if job.threads is not None:
        numba.set_num_threads(min(job.threads, numba.config.NUMBA_NUM_THREADS))
    progress.note(f"{source.description}: about {source.expected:,.0f} particles, lattice spacing "
                  f"{source.lattice.spacing:.3g} m")
    start = time.perf_counter()
    simulation, rows = start_simulation(prepared)
    sampled = time.perf_counter() - start
    progress.start(job.frames - simulation.frame, COMMAND)
    stopped = saved = False
    while simulation.frame < job.frames:
        if progress.cancelled():
            stopped = True
            break
        stats = simulation.step()
        rows.append(row(stats))
        progress.advance(f"{stats.particles:,} particles, {stats.eroded} eroded, "
                         f"{1.0 / max(sum(stats.seconds.values()), 1e-9):.2g} frames/s")
        saved = bool(job.snapshot_every) and stats.frame % job.snapshot_every == 0
        if saved:
            write_snapshot(prepared, simulation, rows)
    progress.finish()
    if stopped and job.snapshot_every and not saved:
        write_state(prepared, simulation, rows)
    return SandstoneResult(prepared, simulation, rows, time.perf_counter() - start, sampled, stopped)


def summary(result: SandstoneResult) -> str:
    """One line: the particles left, the frames run, eroded and exported counts, the interlocked
    share, the wall time and OUT_DIR."""
    job, simulation, rows = result.prepared.job, result.simulation, result.rows
    final = simulation.particles
    counts = (f"{sum(r['eroded'] for r in rows):,} eroded, {sum(r['exported'] for r in rows):,} exported; "
              f"{float(final.interlocked.mean()) if len(final) else 0.0:.1%} interlocked")
    frames = (f"{simulation.frame} of {job.frames} frames (stopped early; {counts})" if result.stopped
              else f"{simulation.frame} frames ({counts})")
    return (f"{COMMAND}: {result.prepared.source.description}, {len(final):,} particles after {frames} in "
            f"{result.seconds:.1f} s; wrote {job.out_dir}")
