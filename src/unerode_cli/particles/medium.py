"""The medium's velocity field v_f of 003 Eq. 8: uniform, a raster on the grid, or the meander
field of 003 Table 1, acting in air, in water or in both. No numba here.

Components are (east, north[, up]) in m/s; the kernels use x east, y south, z up.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unerode_cli.grid import Grid

NONE, UNIFORM, RASTER, MEANDER = 0, 1, 2, 3
MEDIA = {"both": 0, "air": 1, "water": 2}


@dataclass(frozen=True)
class VelocityField:
    """A medium velocity field (003 Eq. 8), weighted by α (``field_strength``) in the kernels.

    Build it with ``uniform``, ``raster`` or ``meander``. ``medium`` says where it blows or
    flows: ``"both"``, ``"air"`` (above sea level) or ``"water"`` (below).
    """

    kind: int
    vector: tuple[float, float, float] = (0.0, 0.0, 0.0)
    bands: np.ndarray | None = None
    amplitude: float = 0.0
    wavelength: float = 1.0
    medium: str = "both"

    @classmethod
    def uniform(cls, east: float, north: float, up: float = 0.0, medium: str = "both") -> VelocityField:
        """The same velocity (m/s) everywhere (003 Table 1 Coastal, Karst: "Uniform")."""
        return cls(UNIFORM, (float(east), float(north), float(up)), medium=medium)

    @classmethod
    def raster(cls, bands: np.ndarray, medium: str = "both") -> VelocityField:
        """A field on the grid: float[2 or 3, ny, nx] bands (east, north[, up]) in m/s, read at
        the cell nearest to the particle (e.g. a fluid simulation's output)."""
        return cls(RASTER, bands=np.asarray(bands, dtype=np.float64), medium=medium)

    @classmethod
    def meander(cls, amplitude: float, wavelength: float, medium: str = "both") -> VelocityField:
        """003 Table 1 Meanders, v_f(p) = [0 sin(p.x) 0]ᵀ with its scales made explicit: a
        northward velocity amplitude·sin(2π·x/wavelength) (m/s; x the eastward distance from
        the centre of cell (0, 0), m)."""
        return cls(MEANDER, amplitude=float(amplitude), wavelength=float(wavelength), medium=medium)

    def validate(self, grid: Grid) -> None:
        """Raise ValueError (one sentence) for a field that does not fit the grid."""
        if self.medium not in MEDIA:
            raise ValueError(f"the velocity field's medium must be one of {sorted(MEDIA)}, "
                             f"got {self.medium!r}")
        if self.kind == RASTER:
            b = self.bands
            if b is None or b.ndim != 3 or b.shape[0] not in (2, 3) or b.shape[1:] != grid.shape:
                shape = None if b is None else b.shape
                raise ValueError(f"a velocity raster must have shape (2 or 3, {grid.shape[0]}, "
                                 f"{grid.shape[1]}), got {shape}")
            if not np.isfinite(b[:, grid.valid]).all():
                raise ValueError("the velocity raster has non-finite values inside the domain")
        elif self.kind == UNIFORM:
            if not np.isfinite(self.vector).all():
                raise ValueError("the uniform velocity must be finite")
        elif self.kind == MEANDER:
            if not (np.isfinite(self.amplitude) and np.isfinite(self.wavelength) and self.wavelength > 0):
                raise ValueError("the meander field needs a finite amplitude and a wavelength > 0 m")
        elif self.kind != NONE:
            raise ValueError(f"unknown velocity field kind {self.kind}")

    def kernel_arrays(self, grid: Grid) -> tuple[int, int, np.ndarray, np.ndarray]:
        """(kind code, medium code, float[4] (u_x, u_y, u_z or amplitude, wavelength),
        float[3, ny, nx] raster) in kernel axes (x east, y south, z up)."""
        scalars = np.zeros(4)
        bands = np.zeros((3, 1, 1))
        if self.kind == UNIFORM:
            scalars[:3] = self.vector[0], -self.vector[1], self.vector[2]
        elif self.kind == MEANDER:
            scalars[0], scalars[1] = self.amplitude, self.wavelength
        elif self.kind == RASTER:
            bands = np.zeros((3, *grid.shape))
            bands[0] = self.bands[0]
            bands[1] = -self.bands[1]
            if self.bands.shape[0] == 3:
                bands[2] = self.bands[2]
        return self.kind, MEDIA[self.medium], scalars, bands


#: No velocity field.
STILL = VelocityField(NONE)
