"""Voxel terrains particles alter (003 §4.4): density voxels (Eq. 13) and binary voxels with hit
counts (Eq. 14), each optionally with a material per voxel — 3D material layers, every material
with its K_ε and τ_c (003 Eq. 2) — and material rules on deposition and erosion (003 §4.2, §7).

They implement ``terrain.Terrain`` over the grids of ``volume.voxels``: the tracer reads a frozen
float32 level (> 0 in the ground; ``voxel_kernels``) and their top surface (where particles are
emitted); impacts are applied in particle order by ``volume.voxel_kernels.apply_density`` /
``apply_binary``. With materials, an impact that detaches shares its volume among the voxels
around it in proportion to their erodibility K_ε as well as to Eq. 13's weights, so dissolution
follows the softer voxels (003 §5 Karst: "the karst will automatically follow the softest
materials"). As on heightfields, a particle hits the ground when its step crosses the
surface, which is the f = 0 level of the trilinear density (binary voxels read as ±1).

The terrain's columns are its ``grid`` (x = column·dx, y = row·dy from the centre of the
north-west column, m); z is the elevation (m). No numba is loaded until a kernel runs.
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.particles.terrain import VOXELS_KIND, Material, Terrain, TracingSnapshot, _filled
from unerode_cli.volume.voxels import BinaryVoxels, DensityVoxels

#: Bytes a run needs per voxel, beyond a few column-sized arrays: the terrain given, the
#: terrain altered and the tracer's float32 level (density: 8 + 8 + 4; binary: solid 1 + 1,
#: hits 4 + 4, level 4), plus 2 + 2 for a material index.
RUN_BYTES_PER_VOXEL = {"density": 20, "binary": 14}
MATERIAL_BYTES_PER_VOXEL = 4
#: Defaults of binary voxels: α hits per voxel volume of matter and the flip threshold C
#: (hits), so that by default a voxel flips once a voxel's worth of matter has hit it. 003
#: asks for an α "high enough to obtain values above 1": an impact's share of a voxel is often
#: a thousandth of it or less, and ⌊α·share⌋ would drop it with a small α.
HITS_PER_VOXEL = 1_000_000
HITS_THRESHOLD = 1_000_000


def run_bytes(voxels: int, representation: str, with_material: bool) -> int:
    """Bytes a particle run needs for ``voxels`` voxels of ``representation`` ("density" or
    "binary"), with or without a material index."""
    per = RUN_BYTES_PER_VOXEL[representation] + (MATERIAL_BYTES_PER_VOXEL if with_material else 0)
    return voxels * per


@dataclass(frozen=True)
class MaterialRules:
    """How the materials of voxels change (indices into the terrain's materials).

    Attributes:
        deposit: material a voxel becomes when a deposit turns it to ground (003 §4.2:
            deposits become "ground material"); −1 keeps its index.
        eroded: material → material it becomes when eroded (003 §7's transformation rules,
            e.g. clay → sand): density voxels that lose matter and stay ground, binary voxels
            at +C hits (instead of turning to air).
    """

    deposit: int = -1
    eroded: Mapping[int, int] = field(default_factory=dict)

    def arrays(self, n_materials: int) -> tuple[int, np.ndarray]:
        """(deposit index, int16[n] material each one becomes when eroded)."""
        indices = [self.deposit, *self.eroded, *self.eroded.values()]
        if any(i >= n_materials or (i < 0 and i != self.deposit) for i in indices) or self.deposit < -1:
            raise ValueError(f"material rules name indices outside [0, {n_materials - 1}]")
        on_erosion = np.arange(max(n_materials, 1), dtype=np.int16)
        for source, target in self.eroded.items():
            on_erosion[source] = target
        return self.deposit, on_erosion


class VoxelTerrain(Terrain):
    """What density and binary voxel terrains share: the columns' grid, the materials, the
    tracing snapshot and the point queries."""

    def __init__(self, voxels: DensityVoxels | BinaryVoxels, materials: Sequence[Material] | None,
                 rules: MaterialRules) -> None:
        self.voxels = voxels.copy()
        dx, dy, _ = voxels.geometry.size
        self.grid = Grid(dx, dy, self.voxels.valid)
        if not self.grid.valid.any():
            raise ValueError("the voxel grid has no valid column")
        has_material = voxels.material is not None
        if has_material != (materials is not None):
            raise ValueError("a material index per voxel and a materials table go together")
        self.materials = tuple(materials) if materials is not None else None
        if self.materials is not None:
            if not self.materials:
                raise ValueError("the materials table is empty")
            if int(self.voxels.material.max()) >= len(self.materials):
                raise ValueError(f"voxel material indices go up to {int(self.voxels.material.max())}, "
                                 f"the table has {len(self.materials)} material(s)")
        elif rules != MaterialRules():
            raise ValueError("material rules need a material index per voxel")
        self.rules = rules
        deposit, on_erosion = rules.arrays(len(self.materials or ()))
        erodibility = np.array([m.k_eps for m in self.materials or ()], dtype=np.float64)
        #: the kernels' material rules: deposit material, what each material becomes when
        #: eroded, and the erodibilities that weight erosion among the voxels of an impact
        self._rules = (deposit, on_erosion, erodibility)

    @property
    def z0(self) -> float:
        """Elevation of the grid's bottom (m)."""
        return self.voxels.geometry.origin[2]

    @property
    def dz(self) -> float:
        """Voxel height (m)."""
        return self.voxels.geometry.size[2]

    def _material_array(self) -> np.ndarray:
        material = self.voxels.material
        return material if material is not None else np.zeros((0, 0, 0), np.int16)

    @abstractmethod
    def level(self) -> np.ndarray:
        """The tracer's float32 level (> 0 in the ground, the surface at 0)."""

    def tracing_snapshot(self, default: Material) -> TracingSnapshot:
        from unerode_cli.volume.voxel_kernels import top_surface

        level = self.level()
        materials = self.materials or (default,)
        return TracingSnapshot(
            _filled(top_surface(level, self.z0, self.dz), self.grid.valid),
            np.zeros((1, 1), np.int32),
            np.array([m.k_eps for m in materials]),
            np.array([m.tau_c for m in materials]),
            kind=VOXELS_KIND, volume=level, volume_material=self._material_array().copy(),
            z0=self.z0, dz=self.dz,
        )

    def matter(self) -> float:
        return self.voxels.matter()

    def absorb(self, snapshot: TracingSnapshot, live: tuple) -> None:
        """The material index the impacts recoloured in the snapshot (the rest of the state
        was altered in place)."""
        if self.voxels.material is not None:
            self.voxels.material[...] = snapshot.volume_material

    def depth(self, points: np.ndarray) -> np.ndarray:
        """Intersection test: the level at points float64[n, 3] (m) times the voxel height: > 0
        in the ground, 0 on its surface; near the surface of a density built by
        ``volume.voxels.density_block`` the signed distance (m) below it, saturating one voxel
        away."""
        from unerode_cli.particles import voxel_kernels as vk

        p = np.ascontiguousarray(points, dtype=np.float64)
        dx, dy, dz = self.voxels.geometry.size
        level = vk.levels(self.level(), p[:, 0].copy(), p[:, 1].copy(), p[:, 2].copy(), dx, dy, dz, self.z0)
        return level * dz

    def normal(self, points: np.ndarray) -> np.ndarray:
        """Unit outward normals −∇f/‖∇f‖ float64[n, 3] at points float64[n, 3] (m)."""
        from unerode_cli.particles import voxel_kernels as vk

        p = np.ascontiguousarray(points, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3:
            raise ValueError("normals of a voxel terrain need points (x, y, z)")
        dx, dy, dz = self.voxels.geometry.size
        return vk.normals(self.level(), p[:, 0].copy(), p[:, 1].copy(), p[:, 2].copy(), dx, dy, dz, self.z0)


class DensityTerrain(VoxelTerrain):
    """Density voxels f ∈ [−1, 1] (003 §4.4, Eq. 13): a voxel holds (1 + f)/2 of its volume in
    matter; an impact's Q is shared by the voxels within R (``volume.voxel_kernels.apply_density``).

    Args:
        voxels: the grid (copied).
        materials: the materials of ``voxels.material`` (K_ε and τ_c of 003 Eq. 2), or None
            when the grid has no material index (the run's K_ε and τ_c then apply).
        rules: how materials change on deposition and erosion.

    Attributes:
        left: matter (m³) that went through the top (> 0) or bottom (< 0) of the grid, which
            then did not change by the whole of what the particles deposited or detached.
    """

    def __init__(self, voxels: DensityVoxels, materials: Sequence[Material] | None = None,
                 rules: MaterialRules = MaterialRules()) -> None:
        super().__init__(voxels, materials, rules)
        self.left = 0.0

    def level(self) -> np.ndarray:
        return self.voxels.density.astype(np.float32)

    def surface(self) -> np.ndarray:
        from unerode_cli.volume.voxel_kernels import top_surface

        return top_surface(self.voxels.density, self.z0, self.dz)

    def apply(self, x: np.ndarray, y: np.ndarray, z: np.ndarray, q: np.ndarray, radius: np.ndarray) -> None:
        from unerode_cli.volume.voxel_kernels import apply_density

        dx, dy, dz = self.voxels.geometry.size
        self.left += apply_density(self.voxels.density, self._material_array(), self.voxels.valid,
                                   dx, dy, dz, self.z0, x, y, z, q, radius, self._rules)

    def copy(self) -> DensityTerrain:
        new = DensityTerrain(self.voxels, self.materials, self.rules)
        new.left = self.left
        return new

    def live_state(self, snapshot: TracingSnapshot) -> tuple:
        from unerode_cli.particles import kernels

        off = kernels.live_off()
        return (kernels.LIVE_DENSITY, self.voxels.density, *off[2:6], self._rules, np.zeros(1), off[8])

    def absorb(self, snapshot: TracingSnapshot, live: tuple) -> None:
        super().absorb(snapshot, live)
        self.left += float(live[7][0])


class BinaryTerrain(VoxelTerrain):
    """Binary voxels with hit counts (003 §4.4, Eq. 14): an impact's share of Q in a voxel gives
    ⌊α·share/V⌋ hits, and a voxel flips at ±C hits (``volume.voxel_kernels.apply_binary``).

    Args:
        voxels: the grid (copied), with its hit counts.
        materials, rules: as for ``DensityTerrain``.
        alpha: α, hits per voxel volume of matter (003 Eq. 14).
        threshold: C, the hits at which a voxel flips (003: proportional to K_ε).

    Attributes:
        counters: int64 totals of ``apply_binary``'s counters over the terrain's impacts (the
            names are in ``volume.voxel_kernels``: EROSION_HITS, …).
    """

    def __init__(self, voxels: BinaryVoxels, materials: Sequence[Material] | None = None,
                 rules: MaterialRules = MaterialRules(), alpha: float = HITS_PER_VOXEL,
                 threshold: int = HITS_THRESHOLD) -> None:
        from unerode_cli.volume.voxel_kernels import N_COUNTERS

        if not (np.isfinite(alpha) and alpha > 0):
            raise ValueError(f"the hits per voxel volume α must be > 0, got {alpha}")
        if int(threshold) != threshold or threshold < 1:
            raise ValueError(f"the hit threshold C must be an integer ≥ 1, got {threshold}")
        super().__init__(voxels, materials, rules)
        self.alpha = float(alpha)
        self.threshold = int(threshold)
        self.counters = np.zeros(N_COUNTERS, np.int64)

    def level(self) -> np.ndarray:
        return np.where(self.voxels.solid, np.float32(1.0), np.float32(-1.0))

    def surface(self) -> np.ndarray:
        from unerode_cli.volume.voxel_kernels import top_surface

        return top_surface(self.level(), self.z0, self.dz)

    def apply(self, x: np.ndarray, y: np.ndarray, z: np.ndarray, q: np.ndarray, radius: np.ndarray) -> None:
        from unerode_cli.volume.voxel_kernels import apply_binary

        dx, dy, dz = self.voxels.geometry.size
        self.counters += apply_binary(self.voxels.solid, self.voxels.hits, self._material_array(),
                                      self.voxels.valid, dx, dy, dz, self.z0, x, y, z, q, radius,
                                      self.alpha, self.threshold, self._rules)

    def copy(self) -> BinaryTerrain:
        new = BinaryTerrain(self.voxels, self.materials, self.rules, self.alpha, self.threshold)
        new.counters = self.counters.copy()
        return new

    def live_state(self, snapshot: TracingSnapshot) -> tuple:
        from unerode_cli.particles import kernels

        off = kernels.live_off()
        return (kernels.LIVE_BINARY, off[1], self.voxels.solid, self.voxels.hits, self.alpha, self.threshold,
                self._rules, off[7], self.counters)
