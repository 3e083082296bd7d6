"""Wind abrasion from the flow around the rock (002 §5.1, Eq. 8, with the wind of ``airflow``).

The local wind v at a surface particle is the flow velocity of ``airflow`` (lattice Boltzmann
around the rock's voxels) ``reach`` metres out along the particle's normal (the distance over
which the abrading grains keep their speed, ``FlowWindParams``), so Eq. 8,

    W_a = k_a·‖v‖·(−n·v)₊,   v = U·(flow velocity / free-wind speed),

sees the speed-up around edges (‖v‖ > U), the wake (‖v‖ ≪ U behind the rock) and the
recirculation that blows back onto leeward faces, which the rays of ``wind`` cannot.

The air grid: cubic cells of ``FlowWind.cell`` (m), chosen so the rock's larger horizontal
extent spans ``cells_across`` cells; the wind domain extends the rock's bounding box by its
extent upwind, downwind and to both sides and by half its height above it ("a wind domain twice
the rock's", 002 §5), the ground below being free slip. The rock's voxels are the air cells
holding a particle. The flow is solved for two crossings of the domain on the first frame, then
continued for half a crossing every ``every`` frames as the rock changes (warm start).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from unerode_cli.sandstone.airflow import Airflow, flow_through_steps


@dataclass(frozen=True)
class FlowWindParams:
    """``reynolds``: Re of the flow over the rock's width (``airflow``: a moderate Re);
    ``cells_across``: air cells across the rock's larger horizontal extent; ``every``: frames
    between flow updates; ``reach`` (m): how far out along the normal the wind that carries the
    abrading grains is taken. Sand grains are heavy: a 0.2 mm quartz grain (2650 kg/m³) relaxes
    to the air's speed in τ_p = ρ_p·d²/(18μ) ≈ 0.33 s, i.e. over ~3 m at 10 m/s (Stokes drag),
    so the grains hitting a windward face carry the wind of ~3 m upstream, not the slow air of
    the stagnation point at the face."""

    reynolds: float = 100.0
    cells_across: int = 16
    every: int = 10
    reach: float = 3.0

    def __post_init__(self) -> None:
        if not (self.reynolds > 0 and self.cells_across >= 4 and self.every >= 1):
            raise ValueError("the flow wind needs Re > 0, at least 4 cells across the rock and an update "
                             "every ≥ 1 frames")


class FlowWind:
    """The flow of one free-wind ``direction`` (unit vector, blowing toward) around particles."""

    def __init__(self, positions: np.ndarray, direction: np.ndarray, params: FlowWindParams) -> None:
        low, high = positions.min(axis=0), positions.max(axis=0)
        extent = high - low
        self.cell = float(max(extent[0], extent[1])) / params.cells_across
        pad = np.array([extent[0], extent[1], 0.0])
        self.origin = np.array([low[0], low[1], 0.0]) - pad
        self.origin[2] = min(low[2], 0.0)
        top = high[2] + 0.5 * extent[2]
        size = np.array([extent[0] + 2 * pad[0], extent[1] + 2 * pad[1], top - self.origin[2]])
        self.shape = tuple(int(math.ceil(s / self.cell)) + 1 for s in size)
        self.params = params
        self.direction = np.asarray(direction, dtype=np.float64)
        self.flow = Airflow(self._solid(positions), self.direction, params.reynolds, params.cells_across)
        self.flow.run(2 * flow_through_steps(max(self.shape[0], self.shape[1])))
        self.velocity = self.flow.velocity()

    def _cells(self, points: np.ndarray) -> np.ndarray:
        return np.floor((points - self.origin) / self.cell).astype(np.int64)

    def _solid(self, positions: np.ndarray) -> np.ndarray:
        solid = np.zeros(self.shape, dtype=bool)
        cells = self._cells(positions)
        inside = np.all((cells >= 0) & (cells < np.array(self.shape)), axis=1)
        solid[tuple(cells[inside].T)] = True
        return solid

    def update(self, positions: np.ndarray) -> None:
        """Follow the eroded rock: new solid, half a domain crossing of flow."""
        self.flow.set_solid(self._solid(positions))
        self.flow.run(flow_through_steps(max(self.shape[0], self.shape[1])) // 2)
        self.velocity = self.flow.velocity()

    def local_wind(self, positions: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """``(N, 3)``: the flow velocity (over the free wind's speed) ``params.reach`` out along
        each normal (one air cell where that point is rock or outside the air grid; 0 where that
        is too)."""
        out = np.zeros((len(positions), 3))
        todo = np.ones(len(positions), dtype=bool)
        for distance in (max(self.params.reach, self.cell), self.cell):
            cells = self._cells(positions + normals * distance)
            inside = todo & np.all((cells >= 0) & (cells < np.array(self.shape)), axis=1)
            inside[inside] = ~self.flow.solid[tuple(cells[inside].T)]
            out[inside] = self.velocity[tuple(cells[inside].T)]
            todo &= ~inside
        return out


def flow_abrasion(wind: FlowWind, positions: np.ndarray, normals: np.ndarray, surface: np.ndarray,
                  k_a: np.ndarray, speed: float) -> np.ndarray:
    """W_a = k_a·‖v‖·(−n·v)₊ (002 Eq. 8) with the local wind v of ``wind`` times the free speed
    ``speed`` (m/s), on the ``surface`` particles; ``(N,)``, dimensionless."""
    rate = np.zeros(len(positions))
    which = np.asarray(surface, dtype=bool) & (np.asarray(k_a) != 0.0)
    if speed == 0.0 or not which.any():
        return rate
    v = wind.local_wind(positions[which], normals[which]) * speed
    facing = np.maximum(0.0, -np.einsum("ij,ij->i", normals[which], v))
    rate[which] = np.asarray(k_a)[which] * np.linalg.norm(v, axis=1) * facing
    return rate
