"""Surface mesh (``volume``) benchmarks: the closed mesh of the ``arch`` preset's 1 M particles
(002 Table 1's count; four layers as materials, on the ground) — density, marching cubes and
5 Taubin iterations, the default of ``sandstone --mesh``, at the particle spacing and at half of
it (``--mesh-cell``) — and writing it as binary PLY, OBJ (with its MTL) and glTF binary (with
stress, viability and layer per vertex); each write case prints the file's size.
The particles are sampled once while setting up (not timed). The stages are single-threaded
(NumPy, scipy.ndimage, scikit-image), so the thread count does not enter.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from harness import benchmark
from unerode_cli.io.mesh_files import write_mesh
from unerode_cli.sandstone.presets import preset_scene
from unerode_cli.sandstone.sampling import lattice_for, scene_particles
from unerode_cli.volume.particle_surface import SMOOTHING, particle_mesh

PARTICLES = 1_000_000


def _arch() -> tuple[np.ndarray, np.ndarray, float, float]:
    """The arch preset's particles: positions (m), layers, spacing (m) and the ground (m)."""
    scene = preset_scene("arch")
    lattice, _ = lattice_for(scene.shape, scene.low, np.asarray(scene.domain.size, dtype=float), PARTICLES)
    particles = scene_particles(scene, lattice, seed=0)
    return particles.positions, particles.layer, lattice.spacing, lattice.low[2]


def _mesh_case(share: float = 1.0):
    positions, layers, spacing, ground = _arch()

    def work():
        return particle_mesh(positions, layers, spacing**3, share * spacing, SMOOTHING, ground)

    return work, len(positions), "particles"


def _write_case(suffix: str):
    positions, layers, spacing, ground = _arch()
    mesh = particle_mesh(positions, layers, spacing**3, spacing, SMOOTHING, ground)
    attributes = {"stress": positions[:, 2].astype(np.float32), "viability": np.ones(len(positions)),
                  "layer": layers}
    values = {k: np.asarray(v)[np.zeros(len(mesh.vertices), dtype=np.int64)] for k, v in attributes.items()}
    folder = tempfile.TemporaryDirectory()  # removed with the case
    path = Path(folder.name) / f"arch{suffix}"

    def work() -> None:
        assert folder is not None   # the folder lives as long as the case
        write_mesh(path, mesh, overwrite=True, attributes=values)

    work()
    size = sum(p.stat().st_size for p in Path(folder.name).iterdir())
    print(f"arch{suffix}: {len(mesh.vertices):,} vertices, {len(mesh.faces):,} faces, {size / 1e6:.1f} MB")
    return work, len(mesh.vertices), "vertices"


benchmark("volume/mesh arch 1M particles 5 Taubin iterations")(_mesh_case)
benchmark("volume/mesh arch 1M particles half cell 5 Taubin iterations")(lambda: _mesh_case(0.5))
benchmark("volume/write mesh ply arch 1M particles")(lambda: _write_case(".ply"))
benchmark("volume/write mesh obj arch 1M particles")(lambda: _write_case(".obj"))
benchmark("volume/write mesh glb arch 1M particles")(lambda: _write_case(".glb"))
