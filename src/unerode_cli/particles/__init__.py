"""Particle erosion (003, Hartley et al. 2024): particles with gravity, buoyancy, Stokes
settling and an optional medium velocity field detach and deposit matter where they hit a
heightfield, a layered terrain, or density or binary voxels.

Public API (importing it does not load numba; ``run`` does, on first call):
``run``, ``ParticleParams``, ``Emission``, ``VelocityField``, ``HeightfieldTerrain``,
``LayeredTerrain``, ``DensityTerrain``, ``BinaryTerrain``, ``MaterialRules``, ``Material``,
``PRESETS``, ``get_preset``, ``preset_params``, ``REPRESENTATIONS``, ``run_bytes``.
"""

from unerode_cli.particles.emission import Emission
from unerode_cli.particles.medium import VelocityField
from unerode_cli.particles.parameters import PARAMETERS, ParticleParams
from unerode_cli.particles.presets import (
    PRESETS,
    REPRESENTATIONS,
    VOXEL_REPRESENTATIONS,
    Preset,
    get_preset,
    preset_params,
)
from unerode_cli.particles.simulate import ParticleBudget, ParticlePath, ParticleRun, ParticleStats, run
from unerode_cli.particles.terrain import HeightfieldTerrain, LayeredTerrain, Material, Terrain
from unerode_cli.particles.voxel_terrain import BinaryTerrain, DensityTerrain, MaterialRules, run_bytes

__all__ = [
    "PARAMETERS", "PRESETS", "REPRESENTATIONS", "VOXEL_REPRESENTATIONS", "BinaryTerrain", "DensityTerrain",
    "Emission", "HeightfieldTerrain", "LayeredTerrain", "Material", "MaterialRules", "ParticleBudget",
    "ParticleParams", "ParticlePath", "ParticleRun", "ParticleStats", "Preset", "Terrain", "VelocityField",
    "get_preset", "preset_params", "run", "run_bytes",
]
