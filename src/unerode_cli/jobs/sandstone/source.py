"""The rock a `sandstone` job samples: a scene YAML file, a preset, or a DEM extruded into a
block; its lattice, the parameters given on the command line, and the checks that refuse a
source before any particle is sampled (water sources outside the domain, not enough memory)."""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.input_georef import InputGeoref
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.scene_files import is_scene_file, read_scene
from unerode_cli.io.terrain import Terrain
from unerode_cli.sandstone.layers import LAYER_PARAMETERS, ROCK_PARAMETERS, Layer, LayerStack, Rock
from unerode_cli.sandstone.particles import Particles
from unerode_cli.sandstone.presets import PRESETS, preset_scene
from unerode_cli.sandstone.sampling import (
    ExtrudedDem,
    Lattice,
    lattice_for,
    memory_estimate,
    scene_particles,
    solid_particles,
)
from unerode_cli.sandstone.scene import RunSettings, Scene, Water, Wind

#: Share of the free memory a run may plan to use.
MEMORY_SHARE = 0.8
#: Headroom above an extruded DEM's highest cell, as a share of its height above the base.
DEM_HEADROOM = 0.25


@dataclass
class Source:
    """The rock to sample: a scene (a YAML file or a preset) or an extruded DEM. ``expected``:
    the particle count the lattice should give; ``build(seed)`` samples the particles."""

    description: str
    layers: LayerStack
    rock: Rock
    wind: Wind
    lattice: Lattice
    expected: float
    build: Callable[[int], Particles]
    dem: Terrain | None = None
    water: Water = field(default_factory=Water)
    run: RunSettings | None = None


def scene_path(scene: str) -> Path | None:
    """The file SCENE names (a scene YAML or a DEM), None for a preset or a missing file."""
    path = Path(scene)
    return path if path.is_file() else None


def read_source(scene: str, particles: int | None, extrude: float | None, band: int | None,
                channel: str | None, given: dict[str, str | None],
                georef: InputGeoref | None = None) -> Source:
    """The scene, preset or extruded DEM that ``scene`` names, its lattice for about
    ``particles`` particles, and its layers and rock with the parameters ``given`` (SI units);
    ``georef`` is what ``--crs``, ``--cell-size`` and ``--nodata`` assign to a DEM."""
    source = _read(scene, particles, extrude, band, channel, georef or InputGeoref())
    source.layers, source.rock = _overridden(source.layers, source.rock, given)
    return source


def _read(scene: str, particles: int | None, extrude: float | None, band: int | None,
          channel: str | None, georef: InputGeoref) -> Source:
    path = Path(scene)
    if scene in PRESETS and not path.exists():
        _only_for_dems(extrude, georef, "a preset")
        return _scene_source(preset_scene(scene), f"preset {scene}", particles)
    if not path.exists():
        raise InputError(f"SCENE {scene} is neither a file nor a preset ({', '.join(PRESETS)}).")
    if is_scene_file(path):
        _only_for_dems(extrude, georef, "a scene file")
        return _scene_source(read_scene(path), str(path), particles)
    if extrude is None:
        raise InputError(f"{path} is not a scene file (.yaml); a DEM needs --extrude BASE_M, the altitude "
                         "its rock starts from.")
    return _dem_source(path, extrude, particles, band, channel, georef)


def _only_for_dems(extrude: float | None, georef: InputGeoref, what: str) -> None:
    """Refuse --extrude, --crs, --cell-size and --nodata for ``what`` (a preset or a scene file)."""
    if extrude is not None:
        raise InputError(f"--extrude applies to a DEM, not to {what}.")
    if georef.given:
        raise InputError(f"--crs, --cell-size and --nodata apply to a DEM, not to {what}.")


def _scene_source(scene: Scene, description: str, particles: int | None) -> Source:
    size = np.asarray(scene.domain.size, dtype=float)
    try:
        lattice, expected = lattice_for(scene.shape, scene.low, size, particles or scene.particles,
                                        scene.cell_size)
        layers, rock = scene.layer_stack(), scene.rock_parameters()
    except ValueError as exc:
        raise InputError(f"{description}: {str(exc).rstrip('.')}.") from None
    return Source(description, layers, rock, scene.wind, lattice, expected,
                  lambda seed: scene_particles(scene, lattice, seed), water=scene.water, run=scene.run)


def _dem_source(path: Path, base: float, particles: int | None, band: int | None,
                channel: str | None, georef: InputGeoref) -> Source:
    """A DEM (m; with the CRS, grid and nodata value ``georef`` assigns) filled with rock from
    ``base`` (m) up to its surface, with :data:`DEM_HEADROOM` above; x and y in m from its
    south-west corner."""
    dem = read_terrain(path, band=band, channel=channel, georef=georef)
    dem.check_valid(path)
    if not math.isfinite(base):
        raise InputError(f"--extrude must be a finite altitude (m), got {base}.")
    highest = float(np.nanmax(dem.elevation))
    if highest <= base:
        raise InputError(f"the DEM {path} lies at or below --extrude {base:g} m (its highest cell is "
                         f"{highest:g} m): no rock to extrude.")
    ny, nx = dem.shape
    size = np.array([nx * dem.dx, ny * dem.dy, (highest - base) * (1.0 + DEM_HEADROOM)])
    solid = ExtrudedDem(dem.elevation, (0.0, 0.0), dem.dx, dem.dy, base)
    low = np.array([0.0, 0.0, base])
    layers = LayerStack((Layer(),))
    try:
        lattice, expected = lattice_for(solid, low, size, particles)
    except ValueError as exc:
        raise InputError(f"{path}: {str(exc).rstrip('.')}.") from None
    return Source(f"{path} extruded from {base:g} m", layers, Rock(), Wind(), lattice, expected,
                  lambda seed: solid_particles(solid, lattice, layers, seed), dem)


def _overridden(layers: LayerStack, rock: Rock, given: dict[str, str | None]) -> tuple[LayerStack, Rock]:
    """The layers and rock with the parameters given on the command line (SI units)."""
    layer_values = {spec.name: float(text) for spec in LAYER_PARAMETERS
                    if (text := given.get(spec.name)) is not None}
    rock_values = {spec.name: float(text) for spec in ROCK_PARAMETERS
                   if (text := given.get(spec.name)) is not None}
    return (layers.with_values(**layer_values) if layer_values else layers), replace(rock, **rock_values)


def check_sources(sources: tuple[tuple[float, float, float, float], ...], source: Source) -> None:
    """Refuse a --source (x, y, z in m, Q in m³/y) whose point lies outside the domain."""
    low = np.asarray(source.lattice.low, dtype=float)
    high = low + np.asarray(source.lattice.size, dtype=float)
    for x, y, z, _ in sources:
        if not np.all((np.array([x, y, z]) >= low) & (np.array([x, y, z]) <= high)):
            raise InputError(f"--source {x:g},{y:g},{z:g}: the point lies outside the domain, which spans "
                             f"x {low[0]:g} to {high[0]:g} m, y {low[1]:g} to {high[1]:g} m and z {low[2]:g} "
                             f"to {high[2]:g} m.")


def check_memory(source: Source) -> None:
    """Refuse, before sampling, a run that would not fit in the free memory."""
    need = memory_estimate(source.expected, source.lattice)
    free = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    if need > MEMORY_SHARE * free:
        raise InputError(f"{source.description} would need about {need / 1e9:.3g} GB for "
                         f"{source.expected:.3g} particles on a {'×'.join(map(str, source.lattice.shape))} "
                         f"lattice, more than the {free / 1e9:.3g} GB of free memory: lower --particles "
                         "(or the scene's particles or cell_size).")
