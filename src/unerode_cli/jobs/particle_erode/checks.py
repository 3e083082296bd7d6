"""Checks of `particle-erode`'s options against each other and against the terrain
representation, made before any input is read; bad input raises
:class:`~unerode_cli.errors.InputError` (one sentence, exit code 2)."""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from typing import Any

from unerode_cli.errors import InputError
from unerode_cli.io.mesh_files import mesh_format
from unerode_cli.io.voxel_files import VOXEL_SUFFIX, voxel_file_layout
from unerode_cli.jobs.particle_erode import parsers
from unerode_cli.particles import IMPLICIT_REPRESENTATIONS, PER_IMPACT, VOXEL_REPRESENTATIONS, Preset
from unerode_cli.particles.simulate import BATCH
from unerode_cli.run.memory import check_fits
from unerode_cli.run.stepping import check_step_count
from unerode_cli.volume.mesh import MeshExtraMissing, marching_cubes_function

#: The terrains impacts can alter as they happen (``Terrain.live_state``).
PER_IMPACT_REPRESENTATIONS = ("heightfield", "density", "binary")
#: Options of 3D terrains (field name, flag); the first three build a block from the DEM.
VOXEL_OPTIONS = (("voxel_size", "--voxel-size"), ("depth", "--depth"), ("headroom", "--headroom"),
                 ("voxels", "--voxels"), ("volume_out", "--volume-out"), ("mesh", "--mesh"),
                 ("hits_per_voxel", "--hits-per-voxel"), ("hits_threshold", "--hits-threshold"))
#: Bytes a run keeps per batch of ``particles.simulate.BATCH`` particles and per iteration (each
#: batch's bounds and budget sums, as Python lists of numbers), besides the fixed event buffers.
BYTES_PER_BATCH = 400
#: Options of voxels that an implicit terrain (one material, no hit counts) does not take.
NOT_IMPLICIT = (("voxels", "--voxels"), ("hits_per_voxel", "--hits-per-voxel"),
                ("hits_threshold", "--hits-threshold"), ("materials", "--materials"),
                ("deposit_material", "--deposit-material"))


@contextlib.contextmanager
def bad_input(option: str = "") -> Iterator[None]:
    """Turn a ValueError (one sentence: the particles and volume packages', the parsers') into
    bad input (exit code 2), its message after ``option`` when given ("--emission must be …")."""
    try:
        yield
    except ValueError as exc:
        raise InputError(f"{option + ' ' if option else ''}{str(exc).rstrip('.')}.") from None


def representation(job: Any, preset: Preset) -> str:
    """The terrain representation: --representation, else sdf with --sdf, else that of
    --voxels' file, else "layers" with --layers, else the (first) preset's."""
    if job.representation is not None:
        with bad_input():
            return parsers.REPRESENTATION.parse(job.representation)
    if job.sdf is not None:
        return "sdf"
    if job.voxels is not None:
        return voxel_file_layout(job.voxels)[1]
    return "layers" if job.layers is not None else preset.representation


def check_terrain_options(job: Any, representation: str) -> None:
    """The options of one representation are refused with another."""
    if representation == "layers":
        if job.layers is None or job.materials is None:
            raise InputError("a layered terrain needs both --layers (thicknesses) and --materials (table).")
    elif job.layers is not None or job.layer_materials or job.layers_out:
        raise InputError(f"--layers, --layer-materials and --layers-out describe a layered terrain, not "
                         f"a {representation} one.")
    if job.sdf is not None and representation != "sdf":
        raise InputError(f"--sdf gives an implicit terrain (--representation sdf), not a {representation} "
                         "one.")
    if representation in IMPLICIT_REPRESENTATIONS:
        given = [option for name, option in NOT_IMPLICIT if getattr(job, name) is not None]
        if given:
            raise InputError(f"{', '.join(given)} describe voxels; an implicit terrain is built from the DEM "
                             "or --sdf and has one material (--k-eps, --tau-c).")
    if representation in VOXEL_REPRESENTATIONS + IMPLICIT_REPRESENTATIONS:
        _check_3d_options(job, representation)
        return
    if representation == "heightfield" and (job.materials is not None or job.deposit_material):
        raise InputError("--materials and --deposit-material need a layered terrain (--layers) or voxels "
                         "(--representation density or binary).")
    given = [option for name, option in VOXEL_OPTIONS if getattr(job, name) is not None]
    if given:
        raise InputError(f"{', '.join(given)} need a 3D terrain (--representation density, binary or sdf).")


def _check_3d_options(job: Any, representation: str) -> None:
    """The options of a voxel or implicit terrain: sizes, hit counts, memory, outputs."""
    if job.voxels is not None:
        given = [option for name, option in VOXEL_OPTIONS[:3] if getattr(job, name) is not None]
        if given:
            raise InputError(f"{', '.join(given)} build a block from the DEM; --voxels brings its own grid.")
    if representation == "density" and (job.hits_per_voxel is not None or job.hits_threshold is not None):
        raise InputError("--hits-per-voxel and --hits-threshold are for binary voxels.")
    for value, option, low in ((job.voxel_size, "--voxel-size", 0.0), (job.depth, "--depth", -1.0),
                               (job.headroom, "--headroom", -1.0),
                               (job.hits_per_voxel, "--hits-per-voxel", 0.0)):
        if value is not None and not (math.isfinite(value) and value > low):
            raise InputError(f"{option} must be a {'positive' if low == 0 else 'non-negative'} number, "
                             f"got {value}.")
    if job.hits_threshold is not None and job.hits_threshold < 1:
        raise InputError(f"--hits-threshold must be at least 1, got {job.hits_threshold}.")
    if not (math.isfinite(job.memory_budget) and job.memory_budget > 0):
        raise InputError(f"--memory-budget must be a positive number of GiB, got {job.memory_budget}.")
    if job.volume_out is not None and job.volume_out.suffix.lower() != VOXEL_SUFFIX:
        raise InputError(f"--volume-out writes a {VOXEL_SUFFIX} file, not '{job.volume_out.name}'.")
    if job.mesh is not None:
        try:
            mesh_format(job.mesh)
            marching_cubes_function()
        except (ValueError, MeshExtraMissing) as exc:
            raise InputError(f"--mesh: {str(exc).rstrip('.')}.") from None


def check_apply(job: Any, representation: str) -> None:
    """``--apply``: per-iteration, or per-impact on heightfields and density and binary voxels."""
    with bad_input():
        mode = parsers.apply_mode(job.apply)
    if mode == PER_IMPACT and representation not in PER_IMPACT_REPRESENTATIONS:
        raise InputError(f"--apply per-impact works on {', '.join(PER_IMPACT_REPRESENTATIONS)} terrains, "
                         f"not on a {representation} one.")


def check_counts(job: Any) -> None:
    """Counts, seed, sea level and spread in their ranges (the command line checks them as it
    parses; a job built in Python is checked here)."""
    for option, value, low in (("--particles", job.particles, 1), ("--iterations", job.iterations, 1),
                               ("--path-count", job.path_count, 1), ("--path-stride", job.path_stride, 1),
                               ("--threads", job.threads, 1)):
        if value is not None and value < low:
            raise InputError(f"{option} must be at least {low}, got {value}.")
    if not 0 <= job.seed < 2**64:
        raise InputError(f"--seed must be an integer in [0, 2^64), got {job.seed}.")
    if job.sea_level is not None and not math.isfinite(job.sea_level):
        raise InputError(f"--sea-level must be a finite elevation (m), got {job.sea_level}.")
    if job.spread is not None and not (math.isfinite(job.spread) and job.spread >= 0):
        raise InputError(f"--spread must be a distance ≥ 0 m, got {job.spread}.")
    with bad_input():
        parsers.check_sources(job.sources or ())
    if job.iterations is not None:
        check_step_count(job.iterations, "--iterations",
                         "give fewer --iterations (split a long run with --max-steps and --resume)")
    if job.particles is not None:
        batches = -(-job.particles // BATCH)
        check_fits(float(batches) * ((job.iterations or 1) + 1) * BYTES_PER_BATCH,
                   f"--particles {job.particles:,} per iteration ({batches:,} batches of {BATCH:,})",
                   "give fewer --particles per iteration (and more --iterations)")
