"""The state of the sandstone's particles (002 §3.2): where each is, what it is made of, how
eroded it is, and its MLS-MPM state (velocity, affine velocity, deformation gradient)."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np


@dataclass
class Particles:
    """Per-particle arrays, all of length N.

    Attributes (units):
        positions: (N, 3) float64, m.
        layer: int32 index in the layer stack (the deposit layer for deposits).
        viability: float64 b (002 Eq. 1), 1 for intact rock, eroded at b ≤ 0.
        erodibility: float64 factor on the layer's k_w and k_s (paint, noise; 0: non-erodible).
        vegetation: float64 cover in [0, 1] (painted; its shielding comes with fluvial erosion).
        deposit: bool, deposited by 002 §7.
        interlocked: bool, −tr σ above the layer's threshold I at the last frame (002 Eq. 2).
        stress: float64 −tr σ (Pa), compression positive.
        normals: (N, 3) float64 unit outward normals of surface particles, zeros elsewhere.
        velocity: (N, 3) float64 m/s; affine: (N, 3, 3) APIC matrix C (1/s);
        deformation: (N, 3, 3) float64 deformation gradient F (002 §4.2).
    """

    positions: np.ndarray
    layer: np.ndarray
    viability: np.ndarray
    erodibility: np.ndarray
    vegetation: np.ndarray
    deposit: np.ndarray
    interlocked: np.ndarray
    stress: np.ndarray
    normals: np.ndarray
    velocity: np.ndarray
    affine: np.ndarray
    deformation: np.ndarray

    @classmethod
    def new(cls, positions: np.ndarray, layer: np.ndarray, erodibility: np.ndarray | None = None,
            vegetation: np.ndarray | None = None, viability: float = 1.0, deposit: bool = False) -> Particles:
        """Particles at rest and undeformed (F = I)."""
        n = len(positions)
        return cls(
            positions=np.ascontiguousarray(positions, dtype=np.float64),
            layer=np.asarray(layer, dtype=np.int32),
            viability=np.full(n, viability),
            erodibility=np.ones(n) if erodibility is None else np.asarray(erodibility, dtype=np.float64),
            vegetation=np.zeros(n) if vegetation is None else np.asarray(vegetation, dtype=np.float64),
            deposit=np.full(n, deposit),
            interlocked=np.zeros(n, dtype=bool),
            stress=np.zeros(n),
            normals=np.zeros((n, 3)),
            velocity=np.zeros((n, 3)),
            affine=np.zeros((n, 3, 3)),
            deformation=np.tile(np.eye(3), (n, 1, 1)),
        )

    def __len__(self) -> int:
        return len(self.positions)

    def select(self, keep: np.ndarray) -> Particles:
        """The particles where the boolean mask ``keep`` is True (or at the given indices)."""
        return Particles(**{f.name: getattr(self, f.name)[keep] for f in fields(self)})

    def appended(self, other: Particles) -> Particles:
        """These particles followed by ``other``'s."""
        return Particles(**{f.name: np.concatenate([getattr(self, f.name), getattr(other, f.name)])
                            for f in fields(self)})

    def arrays(self) -> dict[str, np.ndarray]:
        """Every array by name (a snapshot's content)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> Particles:
        """Particles from :meth:`arrays` (e.g. read back from a snapshot)."""
        missing = [f.name for f in fields(cls) if f.name not in arrays]
        if missing:
            raise ValueError(f"the particle state lacks '{missing[0]}'")
        return cls(**{f.name: np.ascontiguousarray(arrays[f.name]) for f in fields(cls)})
