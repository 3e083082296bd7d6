"""The `sandstone` job (002 Arenite): plan (check everything, read the scene or DEM, size the
particles and refuse what would not fit in memory), run the frames, write OUT_DIR.

Outputs in OUT_DIR: ``particles.ply`` (binary; x y z, nx ny nz, viability, stress in MPa (−tr σ,
compression positive), erodibility E in 1/y, layer, surface, deposit, interlocked, vegetation),
``top.tif`` or ``top.exr`` (the top heightfield; a DEM's grid and CRS when extruded),
``preview.png``, ``frames.csv`` (one row per frame), ``run.json`` (parameters, seed, versions,
totals), and with ``--snapshot-every N`` the particles every N frames in ``snapshots/`` (PLY, or
with ``--snapshot-format npz`` the same columns as a compressed NumPy archive).
``--mesh OUT.glb|OUT.obj|OUT.ply`` adds the closed surface mesh of the final particles, one
material per layer (its counts and enclosed volume go to ``run.json``), and ``--mesh-every N``
the mesh of every N-th frame in ``meshes/`` (``jobs/sandstone/meshes.py``).

The frames run through the shared stepping loop (``run/stepping.py``), whose checkpoint is
``state.npz`` in OUT_DIR (compressed; ``frames.py`` says what it holds): written every
``--checkpoint-every`` frames and when the run stops (``--max-steps`` or a cancel), continued by
``--resume`` bit for bit. A stopped run writes the outputs of the frames done besides its
checkpoint; a finished run removes the checkpoint, unless it was started with
``--snapshot-every`` (or continues such a run): then its final state stays for a later
``--resume`` with more ``--frames``. The summary and ``run.json`` count the whole run, over
every invocation.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from unerode_cli.io.checkpoints import write_state_checkpoint
from unerode_cli.io.paths import OutputPlan
from unerode_cli.jobs.sandstone import meshes, planning
from unerode_cli.jobs.sandstone.files import COMMAND, write_outputs
from unerode_cli.jobs.sandstone.frames import SandstoneFrames
from unerode_cli.jobs.sandstone.options import OPTIONS
from unerode_cli.jobs.sandstone.planning import PreparedSandstone
from unerode_cli.jobs.sandstone.source import check_memory, check_sources, read_source, scene_path
from unerode_cli.run.common_options import input_georef
from unerode_cli.run.declare import declared
from unerode_cli.run.job import Job, Progress
from unerode_cli.run.stepping import Stepped, finish_checkpoints, step_through
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
        checkpoint it continues; then create OUT_DIR and clear its files."""
        planning.check_options(self)
        scene_file = scene_path(self.scene)
        if scene_file is not None:
            outputs.read(scene_file)
        paths = planning.output_paths(self)
        if self.mesh is not None and not planning.mesh_in_out_dir(self):
            outputs.check_output(self.mesh, True)       # in OUT_DIR: cleared once OUT_DIR is made
        source = read_source(self.scene, self.particles, self.extrude, self.band, self.channel,
                             self.parameter_values(), input_georef(self))
        job = planning.with_run_settings(self, source)
        check_sources(planning.water_sources(job), source)
        params = planning.simulation_params(job, source)
        check_memory(source)
        meshes.check_mesh_memory(job, source)
        provenance = planning.provenance(job, source, params)
        checkpoints = planning.checkpoints(job, paths, scene_file, provenance)
        if job.resume:
            planning.check_resume(job, checkpoints)
        planning.clear_outputs(job, paths, outputs)
        return PreparedSandstone(job, source, params, paths, provenance, checkpoints)

    def run(self, planned: PreparedSandstone, progress: Progress) -> SandstoneResult:
        return run_frames(planned, progress)

    def write(self, result: SandstoneResult, outputs: OutputPlan) -> str:
        frames = result.frames
        write_outputs(result.prepared, result.simulation, result.rows, frames.wall(), frames.sampled)
        end_checkpoints(result)
        return summary(result)


@dataclass
class SandstoneResult:
    """The frames run (the simulation after its last frame and the rows of ``frames.csv``), the
    wall time of this invocation's sampling or restoring and frames (s; the whole run's, over
    every invocation, is ``frames.wall()``) and how the loop ended (``stepped.finished`` False:
    stopped by --max-steps or a cancel before ``--frames``)."""

    prepared: PreparedSandstone
    frames: SandstoneFrames
    seconds: float
    stepped: Stepped

    @property
    def simulation(self) -> Simulation:
        return self.frames.simulation

    @property
    def rows(self) -> list[dict[str, Any]]:
        return self.frames.rows


def run_frames(prepared: PreparedSandstone, progress: Progress) -> SandstoneResult:
    """Sample the particles (or resume the checkpoint) and run the frames up to ``--frames``
    through the shared stepping loop: checkpoints, ``--max-steps`` and a cancel stop the run
    after a frame, with its state in ``state.npz``."""
    import numba

    job, source = prepared.job, prepared.source
    if job.threads is not None:
        numba.set_num_threads(min(job.threads, numba.config.NUMBA_NUM_THREADS))
    progress.note(f"{source.description}: about {source.expected:,.0f} particles, lattice spacing "
                  f"{source.lattice.spacing:.3g} m")
    frames = SandstoneFrames(prepared)
    if not job.resume:
        frames.sample()
    stepped = step_through(frames, job.frames, progress, COMMAND, prepared.checkpoints, job.max_steps)
    frames.ended = time.perf_counter()
    progress.finish()
    return SandstoneResult(prepared, frames, frames.ended - frames.started, stepped)


def end_checkpoints(result: SandstoneResult) -> None:
    """After the outputs are written: a finished run removes its checkpoint, or when it keeps its
    final state (``SandstoneFrames.keep``) writes that state there (for a ``--resume`` with more
    frames); a stopped run keeps the checkpoint the loop wrote."""
    checkpoints, stepped = result.prepared.checkpoints, result.stepped
    if not (stepped.finished and result.frames.keep):
        finish_checkpoints(checkpoints, stepped)
    elif checkpoints.path is not None and stepped.done % checkpoints.every != 0:
        write_state_checkpoint(checkpoints.path, checkpoints.fingerprint, stepped.done, result.frames.state(),
                               checkpoints.compressed)


def summary(result: SandstoneResult) -> str:
    """One line: the particles left, the frames done and the eroded and exported counts (of the
    whole run, over every invocation: the rows restored with the state and this invocation's),
    the interlocked share, the wall time of the sampling and frames (the whole run's; a resumed
    run adds this invocation's) and OUT_DIR; a stopped run says how to continue it."""
    job, simulation, rows = result.prepared.job, result.simulation, result.rows
    final = simulation.particles
    counts = (f"{sum(r['eroded'] for r in rows):,} eroded, {sum(r['exported'] for r in rows):,} exported; "
              f"{float(final.interlocked.mean()) if len(final) else 0.0:.1%} interlocked")
    if result.stepped.finished:
        frames, resume = f"{simulation.frame} frames ({counts})", ""
    else:
        frames = f"{simulation.frame} of {job.frames} frames (stopped early; {counts})"
        resume = "; run again with --resume to continue"
    seconds = f"{result.frames.wall():.1f} s"
    if result.stepped.first:
        seconds += f" ({result.seconds:.1f} s in this invocation)"
    return (f"{COMMAND}: {result.prepared.source.description}, {len(final):,} particles after {frames} in "
            f"{seconds}; wrote {job.out_dir}{resume}")
