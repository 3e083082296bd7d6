"""The surface meshes of a `sandstone` job, planned: ``--mesh`` (and an OBJ's MTL beside it),
``--mesh-every``'s ``OUT_DIR/meshes/frame_NNNNN.EXT``, the options they need, and the memory of
the density grid they are drawn from, refused before the run when it would not fit."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from unerode_cli.errors import InputError
from unerode_cli.io.mesh_files import mesh_format, mesh_sidecars
from unerode_cli.jobs.sandstone.source import MEMORY_SHARE, Source
from unerode_cli.volume.density import MAX_BYTES, density_bytes
from unerode_cli.volume.mesh import MeshExtraMissing, marching_cubes_function

if TYPE_CHECKING:
    from unerode_cli.jobs.sandstone.job import SandstoneJob

#: The folder of ``--mesh-every``'s meshes in OUT_DIR, and their format without ``--mesh``.
MESHES = "meshes"
DEFAULT_FRAME_SUFFIX = ".glb"


def wants_meshes(job: SandstoneJob) -> bool:
    """Whether the job writes any surface mesh."""
    return job.mesh is not None or bool(job.mesh_every)


def check_mesh_options(job: SandstoneJob) -> None:
    """Refuse a mesh format not written, a missing scikit-image (or trimesh for .glb), and
    ``--mesh-cell`` without a mesh to make."""
    if job.mesh_every is not None and job.mesh_every < 0:
        raise InputError(f"--mesh-every must be at least 0, got {job.mesh_every}.")
    if job.mesh_cell is not None and not wants_meshes(job):
        raise InputError("--mesh-cell sets the cell of --mesh or --mesh-every; give one of them.")
    for option, path in (("--mesh", job.mesh), ("--mesh-every", frame_suffix_path(job) if job.mesh_every
                                                 else None)):
        if path is None:
            continue
        try:
            mesh_format(path)
            marching_cubes_function()
        except (ValueError, MeshExtraMissing) as exc:
            raise InputError(f"{option}: {str(exc).rstrip('.')}.") from None


def frame_suffix_path(job: SandstoneJob) -> Path:
    """A path with the extension of ``--mesh-every``'s meshes: ``--mesh``'s, else .glb."""
    return Path("frame" + (job.mesh.suffix if job.mesh is not None else DEFAULT_FRAME_SUFFIX))


def mesh_frame_path(job: SandstoneJob, frame: int) -> Path:
    """The mesh of ``frame`` written with ``--mesh-every``."""
    return job.out_dir / MESHES / f"frame_{frame:05d}{frame_suffix_path(job).suffix}"


def final_mesh_paths(job: SandstoneJob) -> dict[str, Path]:
    """``--mesh`` and the files written beside it (an OBJ's MTL), by role."""
    if job.mesh is None:
        return {}
    return {"mesh": job.mesh, **{f"mesh_sidecar_{i}": p for i, p in enumerate(mesh_sidecars(job.mesh))}}


def frame_mesh_paths(job: SandstoneJob) -> list[Path]:
    """Every file ``--mesh-every`` may write up to ``--frames`` (each mesh and its sidecars)."""
    every = job.mesh_every or 0
    meshes = [mesh_frame_path(job, frame) for frame in range(every, job.frames + 1, every)] if every else []
    return [p for mesh in meshes for p in (mesh, *mesh_sidecars(mesh))]


def check_mesh_memory(job: SandstoneJob, source: Source) -> None:
    """Refuse, before sampling, a mesh whose density grid (``--mesh-cell``) would need more than
    ``volume.density.MAX_BYTES`` or the free memory, in one sentence."""
    if not wants_meshes(job):
        return
    lattice = source.lattice
    low = [float(v) for v in lattice.low]
    high = [lo + n * lattice.spacing for lo, n in zip(low, lattice.shape, strict=True)]
    cell = job.mesh_cell if job.mesh_cell is not None else lattice.spacing
    need = density_bytes(low, high, int(source.expected), lattice.spacing**3, cell, ground=low[2],
                         spacing=lattice.spacing)
    free = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    limit = min(MAX_BYTES, MEMORY_SHARE * free)
    if need > limit:
        raise InputError(f"a mesh cell of {cell:.3g} m would need about {need / 2**30:.3g} GiB for its "
                         f"density grid, more than the {limit / 2**30:.3g} GiB allowed: choose a coarser "
                         "--mesh-cell.")
