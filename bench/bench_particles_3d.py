"""Particle erosion on 3D terrains (003 §4.4): the presets of 003 Table 1 that run on voxels, each at
the paper's grid, voxel size, particle count and iterations, named with the CPU time 003 gives for
it; and the tracer's impacts per second on density voxels at 256³ beside the heightfield tracer's on
the same terrain as a 256² heightfield (``ratio``: time per impact).

Scenes (Table 1 gives grids and voxel sizes, not the terrains; these are the 003 §5 settings):
Coastal, a sea floor and a cliff across the grid with the sea level between, waves (0.5 m/s) towards
the cliff; Volcano, a cone with its vent at the summit; Karst, a plateau cut by a flooded gorge, a
soft limestone band along the water table in marl, groundwater flowing in at 1 m/s; Tunnel, a slope
with a rock wall across it and a spring in the slope before the wall; Wind, rock columns on a plain
in an 8 m/s wind; Meanders (an implicit terrain, for which 003 gives no grid), a valley 100 m across
sloping east at 5 % on 1 m nodes, its source at the head and the sin field of ``--velocity sin`` (1
m/s, a quarter of the width). All run per iteration on 2 threads; each preset is timed like the
other cases, the median of runs after a warm-up run (the first run of a process also loads numba's
kernels from their on-disk cache, about 0.5 s more, which 003's CPU times of the simulation alone do
not hold). Rain on an implicit terrain (the 256² relief as a signed distance on 256³ nodes) is timed
per impact beside the heightfield's too.
"""

from __future__ import annotations

import numba
import numpy as np

from harness import Timed, benchmark, ratio
from unerode_cli.grid import Grid
from unerode_cli.particles import (
    BinaryTerrain,
    DensityTerrain,
    Emission,
    HeightfieldTerrain,
    Material,
    SdfTerrain,
    VelocityField,
    get_preset,
    preset_params,
    run,
)
from unerode_cli.volume.sdf_field import ImplicitField
from unerode_cli.volume.sdf_shapes import Surface
from unerode_cli.volume.voxels import (
    BinaryVoxels,
    DensityVoxels,
    VoxelGeometry,
    binary_block,
    density_block,
    horizon_material,
)

THREADS = 2
#: 003 Table 1: grid (columns, rows, layers), voxel size (m) and CPU time (s) of each preset.
PAPER = {"coastal": ((100, 100, 30), 10.0, 0.5), "volcano": ((100, 100, 40), 50.0, 0.8),
         "karst": ((100, 100, 50), 2.0, 20.0), "tunnel": ((100, 100, 50), 1.0, 0.8),
         "wind": ((100, 100, 50), 0.2, 0.5)}
#: Size (voxels per side) and particles of the impacts-per-second comparison.
SIDE = 256
PARTICLES = 20_000


def _geometry(name: str) -> VoxelGeometry:
    (nx, ny, nz), d, _ = PAPER[name]
    return VoxelGeometry((0.0, ny * d, 0.0), (d, d, d), (ny, nx, nz))


def _columns(name: str) -> tuple[np.ndarray, np.ndarray, float]:
    """x and y of the column centres (m, y south) and the voxel size of a preset's grid."""
    (nx, ny, _), d, _ = PAPER[name]
    y, x = np.mgrid[0:ny, 0:nx] * d
    return x, y, d


def _coastal():
    x, _, d = _columns("coastal")
    g = _geometry("coastal")
    h = np.where(x < 40 * d, 5.0 * d, 20.0 * d)  # a sea floor 50 m deep, then a 150 m cliff
    sea = 10.0 * d
    return (DensityTerrain(DensityVoxels(g, density_block(h, g))), Emission.rain(80, mask=h < sea),
            VelocityField.uniform(0.5, 0.0, medium="water"), sea)


def _volcano():
    x, y, d = _columns("volcano")
    g = _geometry("volcano")
    r = np.hypot(x - x.mean(), y - y.mean())
    h = 2.0 * d + np.maximum(0.0, 30.0 * d - 0.6 * r)  # a cone 1.5 km high, 5 km across
    summit = (float(np.argmax(h) % h.shape[1]), float(np.argmax(h) // h.shape[1]))
    params = get_preset("volcano").params(d)
    return (DensityTerrain(DensityVoxels(g, density_block(h, g))),
            Emission.source(150, summit, spread=params.radius), None, None)


def _karst():
    x, _, d = _columns("karst")
    g = _geometry("karst")
    table = 30.0 * d
    h = np.where(x < 15 * d, 20.0 * d, 45.0 * d)  # a gorge flooded to the water table, the plateau
    layers = horizon_material(g, np.array([table - 5 * d, table, np.inf]), np.array([1, 0, 1]))
    terrain = BinaryTerrain(BinaryVoxels(g, binary_block(h, g), material=layers),
                            [Material("limestone", 5.0), Material("marl", 0.5)])
    flow = VelocityField.uniform(1.0, 0.0, medium="water")
    return terrain, Emission.rain(1000, mask=h < table), flow, table


def _tunnel():
    x, y, d = _columns("tunnel")
    g = _geometry("tunnel")
    h = 40.0 * d - 0.3 * x
    wall = (x >= 45 * d) & (x < 55 * d)
    h[wall] = 45.0 * d  # a wall 10 m thick across the slope
    params = get_preset("tunnel").params(d, drop_height=3.0 * d)
    spring = Emission.source(100, (43.0, 49.5), spread=params.radius, velocity=(6.7, 0.0, 0.0))
    return DensityTerrain(DensityVoxels(g, density_block(h, g))), spring, None, None, params


def _wind():
    x, y, d = _columns("wind")
    g = _geometry("wind")
    h = np.full(x.shape, 5.0 * d)
    for cx, cy in ((30, 30), (60, 45), (40, 70), (75, 75)):
        h[np.hypot(x - cx * d, y - cy * d) < 6 * d] = 40.0 * d  # rock columns 7 m high
    return (DensityTerrain(DensityVoxels(g, density_block(h, g))), Emission.rain(100),
            VelocityField.uniform(8.0, 0.0, medium="air"), None)


SCENES = {"coastal": _coastal, "volcano": _volcano, "karst": _karst, "tunnel": _tunnel, "wind": _wind}


def _preset_case(name: str):
    scene = SCENES[name]()
    terrain, emission, velocity, sea = scene[:4]
    preset = get_preset(name)
    params = scene[4] if len(scene) > 4 else preset.params(PAPER[name][1])

    def work():
        numba.set_num_threads(min(THREADS, numba.config.NUMBA_NUM_THREADS))
        return run(terrain, params, emission, iterations=preset.iterations, seed=1, velocity=velocity,
                   sea_level=sea)

    return work, preset.particles * preset.iterations, "particles"


for _name, ((_nx, _ny, _nz), _d, _t) in PAPER.items():
    _rep = "BV" if _name == "karst" else "DV"
    benchmark(f"particles3d/{_name} {_rep} {_nx}×{_ny}×{_nz} at {_d:g} m (003 Table 1: {_t:g} s)")(
        lambda n=_name: _preset_case(n))

#: 003 Table 1 Meanders: implicit, no grid given, CPU time 1 s; our valley's columns, layers and
#: node spacing (m).
MEANDERS = ((100, 100, 40), 1.0, 1.0)


def _meanders_case():
    (nx, ny, nz), d, _ = MEANDERS
    y, x = np.mgrid[0:ny, 0:nx] * d
    h = 10.0 - 0.05 * x + 0.002 * (y - y.mean()) ** 2  # a valley sloping east
    g = VoxelGeometry((0.0, ny * d, 0.0), (d, d, d), (ny, nx, nz))
    terrain = SdfTerrain(ImplicitField(g, Surface(), h))
    preset = get_preset("meanders")
    params = preset.params(d)
    source = Emission.source(preset.particles, (2.0, (ny - 1) / 2.0), spread=params.radius)
    field = VelocityField.meander(1.0, nx * d / 4.0)

    def work():
        numba.set_num_threads(min(THREADS, numba.config.NUMBA_NUM_THREADS))
        return run(terrain, params, source, iterations=preset.iterations, seed=1, velocity=field)

    return work, preset.particles * preset.iterations, "particles"


_grid, _d, _t = MEANDERS
benchmark(f"particles3d/meanders SDF {'×'.join(map(str, _grid))} at {_d:g} m (003 Table 1: {_t:g} s)")(
    _meanders_case)


def _relief(n: int) -> np.ndarray:
    """Rolling hills 50-250 m high on n × n cells (of 20 m: slopes of a few metres a cell)."""
    y, x = np.mgrid[0:n, 0:n] * (2.0 * np.pi / n)
    return 150.0 + 60.0 * np.sin(2.0 * x) * np.cos(3.0 * y) + 40.0 * np.cos(5.0 * x + 1.0) * np.sin(y)


def _per_impact_time(terrain, d: float):
    """A rain run timed per million impacts (``Timed``): the throughput is then impacts/s."""
    params = preset_params("rain", d)
    emission = Emission.rain(PARTICLES)

    def work():
        import time

        numba.set_num_threads(min(THREADS, numba.config.NUMBA_NUM_THREADS))
        start = time.perf_counter()
        result = run(terrain, params, emission, seed=1)
        return Timed((time.perf_counter() - start) / result.stats.impacts * 1e6)

    return work, 1e6, "impacts"


def _density_case():
    d = 20.0
    h = _relief(SIDE)
    g = VoxelGeometry((0.0, SIDE * d, 0.0), (d, d, d), (SIDE, SIDE, SIDE))
    return _per_impact_time(DensityTerrain(DensityVoxels(g, density_block(h, g))), d)


def _sdf_case():
    d = 20.0
    g = VoxelGeometry((0.0, SIDE * d, 0.0), (d, d, d), (SIDE, SIDE, SIDE))
    return _per_impact_time(SdfTerrain(ImplicitField(g, Surface(), _relief(SIDE))), d)


def _heightfield_case():
    d = 20.0
    return _per_impact_time(HeightfieldTerrain(_relief(SIDE), Grid.full((SIDE, SIDE), d)), d)


DENSITY = f"particles3d/rain on density voxels {SIDE}³, time per 1 M impacts"
HEIGHTFIELD = f"particles3d/rain on a heightfield {SIDE}², time per 1 M impacts"
IMPLICIT = f"particles3d/rain on an implicit terrain {SIDE}³, time per 1 M impacts"
benchmark(DENSITY)(_density_case)
benchmark(IMPLICIT)(_sdf_case)
benchmark(HEIGHTFIELD)(_heightfield_case)
ratio(f"particles3d: time per impact, density voxels {SIDE}³ / heightfield {SIDE}²", DENSITY, HEIGHTFIELD)
ratio(f"particles3d: time per impact, implicit terrain {SIDE}³ / heightfield {SIDE}²", IMPLICIT, HEIGHTFIELD)
