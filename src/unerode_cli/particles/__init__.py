"""Particle erosion (003, Hartley et al. 2024): particles with gravity, buoyancy, Stokes
settling and an optional medium velocity field detach and deposit matter where they hit a
heightfield or a layered terrain.

Public API (importing it does not load numba; ``run`` does, on first call):
``run``, ``ParticleParams``, ``Emission``, ``VelocityField``, ``HeightfieldTerrain``,
``LayeredTerrain``, ``Material``, ``PRESETS``, ``get_preset``, ``preset_params``.
"""

from unerode_cli.particles.emission import Emission
from unerode_cli.particles.medium import VelocityField
from unerode_cli.particles.parameters import PARAMETERS, ParticleParams
from unerode_cli.particles.presets import PRESETS, Preset, get_preset, preset_params
from unerode_cli.particles.simulate import ParticleBudget, ParticlePath, ParticleRun, ParticleStats, run
from unerode_cli.particles.terrain import HeightfieldTerrain, LayeredTerrain, Material, Terrain

__all__ = [
    "PARAMETERS", "PRESETS", "Emission", "HeightfieldTerrain", "LayeredTerrain", "Material",
    "ParticleBudget", "ParticleParams", "ParticlePath", "ParticleRun", "ParticleStats", "Preset",
    "Terrain", "VelocityField", "get_preset", "preset_params", "run",
]
