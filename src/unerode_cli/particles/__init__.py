"""Particle erosion (003, Hartley et al. 2024): particles with gravity, buoyancy, Stokes
settling and an optional medium velocity field detach and deposit matter where they hit a
heightfield, a layered terrain, density or binary voxels, or an implicit terrain (a signed
distance function), one or several kinds of particles in a run.

Public API (importing it does not load numba; ``run`` does, on first call):
``run``, ``run_kinds``, ``ParticleKind``, ``kind_seed``, ``ParticleParams``, ``Emission``,
``VelocityField``, ``HeightfieldTerrain``, ``LayeredTerrain``, ``DensityTerrain``,
``BinaryTerrain``, ``SdfTerrain``, ``MaterialRules``, ``Material``, ``PRESETS``, ``get_preset``,
``preset_params``, ``REPRESENTATIONS``, ``run_bytes``, ``sdf_run_bytes``, ``APPLY_MODES``
(``PER_ITERATION``, ``PER_IMPACT``: when impacts alter the terrain).
"""

from unerode_cli.particles.emission import Emission
from unerode_cli.particles.medium import VelocityField
from unerode_cli.particles.parameters import PARAMETERS, ParticleParams
from unerode_cli.particles.presets import (
    IMPLICIT_REPRESENTATIONS,
    PRESETS,
    REPRESENTATIONS,
    VOXEL_REPRESENTATIONS,
    Preset,
    get_preset,
    preset_params,
)
from unerode_cli.particles.sdf_terrain import SdfTerrain, sdf_run_bytes
from unerode_cli.particles.simulate import (
    APPLY_MODES,
    PER_IMPACT,
    PER_ITERATION,
    KindRun,
    ParticleBudget,
    ParticleKind,
    ParticlePath,
    ParticleRun,
    ParticleStats,
    kind_seed,
    run,
    run_kinds,
)
from unerode_cli.particles.terrain import HeightfieldTerrain, LayeredTerrain, Material, Terrain
from unerode_cli.particles.voxel_terrain import BinaryTerrain, DensityTerrain, MaterialRules, run_bytes

__all__ = [
    "APPLY_MODES", "PER_IMPACT", "PER_ITERATION",
    "IMPLICIT_REPRESENTATIONS", "PARAMETERS", "PRESETS", "REPRESENTATIONS", "VOXEL_REPRESENTATIONS",
    "BinaryTerrain", "DensityTerrain", "Emission", "HeightfieldTerrain", "KindRun", "LayeredTerrain",
    "Material", "MaterialRules", "ParticleBudget", "ParticleKind", "ParticleParams", "ParticlePath",
    "ParticleRun", "ParticleStats", "Preset", "SdfTerrain", "Terrain", "VelocityField", "get_preset",
    "kind_seed", "preset_params", "run", "run_bytes", "run_kinds", "sdf_run_bytes",
]
