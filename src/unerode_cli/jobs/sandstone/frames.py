"""The frames of a `sandstone` run as the shared stepping loop drives them
(:class:`~unerode_cli.run.stepping.Stepper`).

The state a checkpoint keeps is everything the next frame reads: the particles' arrays
(positions, layers, viability, erodibility, vegetation, the deposit flags, normals and the
MLS-MPM velocity, affine matrix and deformation gradient), the positions changed by the last
frame (where the normals are recomputed), the frame count and the rows of ``frames.csv`` so far.
The stress (−tr σ) and the interlocked flags are left out: a frame's first stage computes both
afresh (from the deformation gradient, 002 Eq. 2) before anything reads them, so they are zero
on restore. No random generator runs from frame to frame: each random choice is keyed by the
seed and the frame (``Simulation``), so a resumed run is bit for bit the run never stopped. The
state also says whether the run keeps its final state when it finishes (``keep``: it was started
with ``--snapshot-every``, so that ``--resume`` with more ``--frames`` may extend it, again and
again), and the wall time of the run's sampling and of its frames until the state was taken
(``wall_s``, summed over the invocations that resumed one another).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.json_files import jsonable
from unerode_cli.jobs.sandstone.files import row, write_particle_mesh, write_particles
from unerode_cli.jobs.sandstone.meshes import mesh_frame_path
from unerode_cli.jobs.sandstone.planning import PreparedSandstone, snapshot_path
from unerode_cli.run.stepping import StepInfo
from unerode_cli.sandstone.particles import Particles
from unerode_cli.sandstone.simulation import Simulation

#: Prefix of the particles' arrays in the state.
PARTICLE = "particle_"
#: The particles' arrays that the state leaves out: each frame computes them first.
RECOMPUTED = ("stress", "interlocked")


class SandstoneFrames:
    """The simulation (sampled with the job's seed before the first frame, or restored from a
    checkpoint), the rows of ``frames.csv``, the sampling's wall time ``sampled`` (s) and
    whether the run's final state is kept (``keep``, module docstring); ``--snapshot-every``
    particles are written as their frames are reached. ``earlier``: the wall time (s) of the
    invocations before this one, up to the state it resumed; ``ended``: when this invocation's
    frames ended (``perf_counter``, None while they run)."""

    def __init__(self, prepared: PreparedSandstone) -> None:
        self.prepared = prepared
        self._simulation: Simulation | None = None
        self.rows: list[dict[str, Any]] = []
        self.sampled = 0.0
        self.keep = bool(prepared.job.snapshot_every)
        self.earlier = 0.0
        self.started = time.perf_counter()
        self.ended: float | None = None

    def wall(self) -> float:
        """The run's wall time (s): the earlier invocations' and this one's frames so far."""
        end = self.ended if self.ended is not None else time.perf_counter()
        return self.earlier + end - self.started

    @property
    def simulation(self) -> Simulation:
        """The simulation, sampled at first use (unless restored)."""
        if self._simulation is None:
            self.sample()
        assert self._simulation is not None
        return self._simulation

    def step(self, k: int) -> StepInfo:
        simulation, job = self.simulation, self.prepared.job
        stats = simulation.step()
        self.rows.append(row(stats))
        if job.snapshot_every and stats.frame % job.snapshot_every == 0:
            write_particles(snapshot_path(job, stats.frame), self.prepared, simulation)
        if job.mesh_every and stats.frame % job.mesh_every == 0:
            write_particle_mesh(mesh_frame_path(job, stats.frame), self.prepared, simulation)
        return StepInfo(f"{stats.particles:,} particles, {stats.eroded} eroded, "
                        f"{1.0 / max(sum(stats.seconds.values()), 1e-9):.2g} frames/s")

    def state(self) -> dict[str, Any]:
        simulation = self.simulation
        arrays = {PARTICLE + name: value for name, value in simulation.particles.arrays().items()
                  if name not in RECOMPUTED}
        return {**arrays, "changes": simulation.changes, "frame": simulation.frame,
                "rows": jsonable(self.rows), "keep": self.keep, "wall_s": self.wall(),
                "sampled_s": self.sampled}

    def restore(self, state: dict[str, Any]) -> None:
        prepared, source = self.prepared, self.prepared.source
        arrays = {k[len(PARTICLE):]: v for k, v in state.items() if k.startswith(PARTICLE)}
        count = len(arrays.get("positions", ()))
        arrays = {"stress": np.zeros(count), "interlocked": np.zeros(count, dtype=bool), **arrays}
        particles = Particles.from_arrays(arrays)
        self._simulation = Simulation(particles, source.layers, source.rock, source.lattice, prepared.params,
                                      prepared.job.seed, int(state["frame"]))
        self._simulation.changes = np.asarray(state["changes"], dtype=np.float64).reshape(-1, 3)
        self.rows = list(state["rows"])
        self.keep = self.keep or bool(state["keep"])
        self.earlier, self.sampled = float(state.get("wall_s", 0.0)), float(state.get("sampled_s", 0.0))

    def sample(self) -> None:
        """Start the simulation at its first frame: the particles sampled with the job's seed."""
        prepared, source = self.prepared, self.prepared.source
        start = time.perf_counter()
        particles = source.build(prepared.job.seed)
        if len(particles) == 0:
            raise InputError(f"{source.description} has no particle inside the domain.")
        self.sampled = time.perf_counter() - start
        self._simulation = Simulation(particles, source.layers, source.rock, source.lattice, prepared.params,
                                      prepared.job.seed)
