"""Hill-slope erosion: linear diffusion of the elevation (001 §6.4).

    ∂h/∂t = U + k_h·∇²h                                                       (001 §6.4)

with ∇·(k_h ∇h) in place of k_h·∇²h where k_h is a raster. 001 solves it "by an Alternating
Direction Implicit Scheme [Wachspress and Habetler 1960] with long time steps"; here it is the
Peaceman–Rachford ADI scheme on finite volumes (``hillslope_kernels``), which is
unconditionally stable and conserves mass exactly:

- faces to outside the grid and to nodata cells carry no flux (closed edges);
- cells of the ``fixed`` mask (Dirichlet nodes, base level) keep their elevation: what
  diffuses into them leaves the model (the budget's outflux).

Forward only: backward diffusion is ill-posed (``BACKWARD_REFUSAL``).

The numba kernels are imported on first use, so that reading ``PARAMETERS`` (CLI help) does
not load numba.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.processes.budget import MassBudget, SurfaceChange
from unerode_cli.processes.parameters import UPLIFT, ParamSpec, check_fields

#: Why ``step`` refuses dt < 0 (the command line prints it for ``unerode --process hillslope``).
BACKWARD_REFUSAL = (
    "hillslope diffusion cannot run backward in time: backward diffusion is ill-posed, "
    "because anti-diffusion amplifies every small-scale error (noise, rounding) without bound."
)

PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec(
        "k_h",
        "m²/y",
        0.01,
        "hill-slope diffusivity k_h (001 §6.4; 001 Table 1: 0.01-0.05 m²/y)",
        minimum=0.0,
        raster=True,
    ),
    UPLIFT,
)
_SPECS = {spec.name: spec for spec in PARAMETERS}


@dataclass(frozen=True)
class HillslopeParams:
    """Parameters of hill-slope diffusion (001 §6.4); both may be rasters (float[ny, nx]).

    Attributes:
        k_h: diffusivity k_h (m²/y).
        uplift: U (m/y), applied to free cells only (not to fixed cells nor nodata).
    """

    k_h: float | np.ndarray = _SPECS["k_h"].default
    uplift: float | np.ndarray = _SPECS["uplift"].default

    def validate(self, grid: Grid) -> None:
        """Raise ValueError (one sentence) for a value out of range inside the domain or a
        raster of another shape than the grid."""
        check_fields(self, PARAMETERS, grid)


def step(
    elevation: np.ndarray,
    grid: Grid,
    fixed: np.ndarray,
    params: HillslopeParams,
    dt: float,
) -> SurfaceChange:
    """One step of hill-slope diffusion ∂h/∂t = U + ∇·(k_h ∇h) (001 §6.4) by Peaceman–Rachford ADI.

    Two half steps of dt/2, implicit along x then along y, each a set of tridiagonal systems
    (one per row, then one per column) solved by the Thomas algorithm. The scheme is
    unconditionally stable, so there is no ``max_stable_dt``: any dt ≥ 0 is fine, and long
    steps (far beyond the explicit limit dx²/(4·k_h)) reach steady states in a few steps. It is
    second order in time, so accuracy, not stability, is what bounds dt on transients (very
    long steps damp the shortest wavelengths slowly, with alternating sign).

    Finite volumes with face fluxes (harmonic mean of k_h across a face; dx ≠ dy honoured):
    faces to outside the grid and to nodata cells are closed, so with no fixed cell the
    volume Σ Δh·dx·dy changes only by the uplift, up to rounding.

    Args:
        elevation: float64[ny, nx] elevation h(t) (m); not modified. Nodata values are not read.
        grid: cell sizes and domain.
        fixed: bool[ny, nx] Dirichlet nodes (base level, outlets): they keep their elevation
            exactly (Δh = 0, no uplift), and what diffuses into them leaves the model.
        params: k_h (m²/y) and U (m/y).
        dt: time step (y), ≥ 0.

    Returns:
        The change: Δh (m, uplift U·dt included; 0 on fixed and nodata cells) and the mass
        budget over free cells with e = Δh − U·dt: eroded = Σ max(0, −e)·dx·dy,
        deposited = Σ max(0, e)·dx·dy, and outflux = eroded − deposited (m³), which is the
        volume that diffused out through the fixed cells (0 up to rounding without fixed
        cells: the process conserves mass).

    Raises:
        ValueError: dt < 0 (``BACKWARD_REFUSAL``), non-finite dt, a parameter out of range,
            or a mask of another shape than the grid.
    """
    from unerode_cli.hydro.fields import flat_field
    from unerode_cli.processes import hillslope_kernels as hk

    dt = float(dt)
    if dt < 0:
        raise ValueError(BACKWARD_REFUSAL)
    if not np.isfinite(dt):
        raise ValueError(f"the time step must be finite, got {dt} y")
    params.validate(grid)
    shape = grid.shape
    if elevation.shape != shape or fixed.shape != shape:
        raise ValueError(
            f"elevation {elevation.shape} and fixed mask {fixed.shape} must have the grid's shape {shape}"
        )
    valid = grid.valid
    h = np.ascontiguousarray(elevation, dtype=np.float64)
    if not valid.all():
        h = np.where(valid, h, 0.0)  # nodata values are never read, but must not be NaN
    if not np.isfinite(h).all():
        raise ValueError("the elevation has non-finite values inside the domain (not nodata)")
    free = valid & ~np.asarray(fixed, dtype=bool)
    k = flat_field(params.k_h, shape, "k_h")
    if k.size > 1:
        k = np.where(valid.ravel(), k, 0.0)  # a parameter map may hold NaN on nodata
    uplift = flat_field(params.uplift, shape, "uplift")
    if uplift.size > 1:
        uplift = np.where(free.ravel(), uplift, 0.0)
    gx, gy = hk.face_conductances(k, valid, grid.dx, grid.dy)
    new = hk.adi_step(h, free, gx, gy, uplift, dt)
    dh, eroded, deposited = hk.change_and_budget(h, new, free, uplift, dt)
    area = grid.cell_area
    eroded, deposited = eroded * area, deposited * area
    return SurfaceChange(dh, MassBudget(eroded, deposited, eroded - deposited))
