"""Glacial landforms measured on a DEM (001 §7.1 and Fig. 15): the shape of the main valley's
cross-sections, hanging tributaries, lakes, and the hypsometry before and after erosion.

- **Trunk**: the main stem of the largest catchment, by steepest descent (D8) on the
  priority-flooded surface (:func:`unerode_cli.analysis.river.auto_river`): up from the outlet
  of largest drainage area, always into the donor of largest area. Chainage (m) grows upstream.
- **U-shape index** (:func:`u_shape_index`): cross-sections perpendicular to the trunk every
  ``spacing_m`` metres, each fitted with z(x) = z0 + a·|x − x0|^b between its valley sides.
  The exponent b is ≈ 2 for a parabolic (U-shaped, glacial) valley and ≈ 1 for a V-shaped
  (fluvial) one (Svensson 1959; Harbor 1992). Pattyn & Van Huele (1998) show that b depends on
  where the origin is put; here the origin (x0, z0) is fitted with a and b instead of being
  pinned to the lowest sample.
- **Hanging valleys** (:func:`hanging_steps`): where a tributary joins the trunk, its drop over
  the last ``reach_m`` metres before the junction minus the drop that the trunk's own gradient
  would give over that length. Rivers meet at accordant levels (Playfair's law), so a graded
  tributary has a step near 0; a tributary left hanging by a glacier that deepened the trunk
  more than it (001 §7.1) has a step of the height of its lip above the trunk floor.
- **Lakes** (:func:`lakes`): the depressions filled to their spill level (exact priority-flood,
  :mod:`unerode_cli.hydro.depressions`), with no ice, counted with
  :func:`unerode_cli.hydro.depressions.lake_stats`.
- **Hypsometry** (:func:`hypsometry_shift`): the elevation histograms of the DEM and of the DEM
  before erosion (:func:`unerode_cli.analysis.hypsometry.hypsometry`, metres) and the shift of
  their maximum: glacial erosion piles the area up just above the ELA (the glacial buzzsaw,
  Egholm et al. 2009; 001 Fig. 15).

Positions are cell coordinates (row, col), row 0 north; lengths and elevations in metres.
Pure functions on arrays (no file I/O).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unerode_cli.analysis.hypsometry import Hypsometry, hypsometry
from unerode_cli.analysis.river import RiverPath, auto_river
from unerode_cli.grid import Grid
from unerode_cli.hydro import drainage_area, route
from unerode_cli.hydro.depressions import (
    MIN_LAKE_DEPTH,
    LakeStats,
    fill_depressions,
    lake_stats,
    water_depth,
)

#: A cross-section is fitted only with this many samples at least on each side of its lowest one.
MIN_SIDE_SAMPLES = 3
#: Bounds of the fitted exponent b: wide enough for any valley (measured b: 1–4).
B_BOUNDS = (0.2, 8.0)


@dataclass(frozen=True)
class Settings:
    """How the landforms are measured.

    Attributes:
        trunk_fraction: the trunk ends upstream where its donors drain less than this share of
            its catchment (as ``auto_river``'s ``min_area_fraction``).
        spacing_m: distance between cross-sections along the trunk (m).
        half_width_m: a cross-section reaches this far on each side of the trunk (m).
        min_relief_m: a cross-section whose lower valley side rises less than this above its
            floor (m) is not fitted (flat ground).
        tributary_fraction: tributaries drain at least this share of the trunk's catchment.
        reach_m: length of the tributary's last reach over which its step is measured (m),
            and half the length of trunk over which the trunk gradient is fitted.
        min_step_m: a tributary whose step reaches this (m) is counted as hanging.
        min_lake_depth_m: a water body counts as a lake when deeper than this somewhere (m).
        bins: number of elevation bins of the hypsometry.
    """

    trunk_fraction: float = 0.01
    spacing_m: float = 500.0
    half_width_m: float = 2000.0
    min_relief_m: float = 30.0
    tributary_fraction: float = 0.02
    reach_m: float = 250.0
    min_step_m: float = 20.0
    min_lake_depth_m: float = MIN_LAKE_DEPTH
    bins: int = 50

    def check(self) -> None:
        """Raise ValueError naming the first setting out of its range."""
        positive = {"spacing_m": self.spacing_m, "half_width_m": self.half_width_m, "reach_m": self.reach_m}
        for name, value in positive.items():
            if not (np.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be > 0 m, got {value:g}")
        for name, value in {"min_relief_m": self.min_relief_m, "min_step_m": self.min_step_m,
                            "min_lake_depth_m": self.min_lake_depth_m}.items():
            if not (np.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be ≥ 0 m, got {value:g}")
        for name, value in {"trunk_fraction": self.trunk_fraction,
                            "tributary_fraction": self.tributary_fraction}.items():
            if not 0.0 < value < 1.0:
                raise ValueError(f"{name} must lie between 0 and 1, got {value:g}")
        if self.bins < 1:
            raise ValueError(f"the hypsometry needs at least one bin, got {self.bins}")


@dataclass(frozen=True)
class CrossSection:
    """A valley cross-section perpendicular to the trunk and its power-law fit
    z(x) = z0 + a·|x − x0|^b.

    Attributes:
        chainage_m: where it crosses the trunk, distance along the trunk from its mouth (m).
        row, col: cell coordinates of that crossing.
        rows, cols: float64[k] cell coordinates of the fitted samples, from one valley side to
            the other.
        distance_m: float64[k] signed distance of the samples from the trunk (m), increasing;
            positive on the right facing upstream (the orographic left side).
        elevation_m: float64[k] elevation of the samples (m, bilinear).
        b: the shape exponent (dimensionless): ≈ 2 U-shaped, ≈ 1 V-shaped.
        a: the coefficient (m^(1−b)).
        x0_m, z0_m: the fitted origin: distance from the trunk (m) and elevation (m) of the floor.
        relief_m: height of the lower valley side above the lowest sample (m).
        rmse_m: root-mean-square misfit of the fit (m).
    """

    chainage_m: float
    row: float
    col: float
    rows: np.ndarray
    cols: np.ndarray
    distance_m: np.ndarray
    elevation_m: np.ndarray
    b: float
    a: float
    x0_m: float
    z0_m: float
    relief_m: float
    rmse_m: float

    @property
    def width_m(self) -> float:
        """Width of the fitted section between its valley sides (m)."""
        return float(self.distance_m[-1] - self.distance_m[0])

    def fitted(self, distance_m: np.ndarray) -> np.ndarray:
        """The fitted profile z0 + a·|x − x0|^b (m) at distances ``distance_m`` (m)."""
        return self.z0_m + self.a * np.abs(np.asarray(distance_m) - self.x0_m) ** self.b


@dataclass(frozen=True)
class UShape:
    """The cross-sections of the trunk valley.

    Attributes:
        sections: the fitted sections, downstream first.
        tried: number of sections laid out (some are not fitted: flat, nodata, off the map).
    """

    sections: tuple[CrossSection, ...]
    tried: int

    @property
    def exponents(self) -> np.ndarray:
        """float64[k] exponent b of each fitted section."""
        return np.array([s.b for s in self.sections], dtype=np.float64)

    @property
    def median_b(self) -> float:
        """Median exponent b of the fitted sections (NaN without any)."""
        return float(np.median(self.exponents)) if self.sections else float("nan")


@dataclass(frozen=True)
class Junction:
    """A tributary joining the trunk, and the step of its last reach.

    Attributes:
        row, col: the trunk cell that receives the tributary.
        chainage_m: its distance along the trunk from the mouth (m).
        area_m2: drainage area of the tributary at its last cell (m²).
        rows, cols: int64[k] cells of the tributary's last reach, junction first.
        length_m: length of that reach along the tributary (m).
        drop_m: elevation of the reach's upper end above the junction (m).
        trunk_gradient: the trunk's gradient at the junction (m/m, rising upstream).
        step_m: drop_m − trunk_gradient × length_m (m).
    """

    row: int
    col: int
    chainage_m: float
    area_m2: float
    rows: np.ndarray
    cols: np.ndarray
    length_m: float
    drop_m: float
    trunk_gradient: float
    step_m: float


@dataclass(frozen=True)
class HangingValleys:
    """The tributaries of the trunk and which of them hang.

    Attributes:
        junctions: every tributary draining at least ``min_area_m2``, downstream first.
        min_area_m2: the smallest drainage area of a tributary (m²).
        min_step_m: a tributary whose step reaches this (m) hangs.
    """

    junctions: tuple[Junction, ...]
    min_area_m2: float
    min_step_m: float

    @property
    def steps_m(self) -> np.ndarray:
        """float64[k] step of each tributary (m)."""
        return np.array([j.step_m for j in self.junctions], dtype=np.float64)

    @property
    def hanging(self) -> tuple[Junction, ...]:
        """The tributaries whose step reaches ``min_step_m``."""
        return tuple(j for j in self.junctions if j.step_m >= self.min_step_m)


@dataclass(frozen=True)
class HypsometryShift:
    """Hypsometry of a DEM (metres) and, when given, of the DEM before erosion.

    Attributes:
        after: the DEM's hypsometry.
        before: the earlier DEM's, or None.
    """

    after: Hypsometry
    before: Hypsometry | None = None

    @property
    def mode_shift_m(self) -> float:
        """Rise of the hypsometric maximum (fullest bin) from before to after (m; NaN without
        ``before``)."""
        return self.after.mode_m - self.before.mode_m if self.before else float("nan")

    @property
    def mean_shift_m(self) -> float:
        """Change of the mean elevation (m; NaN without ``before``)."""
        return self.after.mean_m - self.before.mean_m if self.before else float("nan")

    @property
    def integral_shift(self) -> float:
        """Change of the hypsometric integral (dimensionless; NaN without ``before``)."""
        return self.after.integral - self.before.integral if self.before else float("nan")


@dataclass(frozen=True)
class Landforms:
    """Every measure of :func:`measure_landforms`.

    Attributes:
        trunk: the main valley's stem.
        u_shape: its cross-sections.
        hanging: its tributaries.
        lake_depth: float64[ny, nx] water depth in the filled depressions (m).
        lakes: the lakes of ``lake_depth``.
        hypsometry: the hypsometry and its shift.
        settings: what was measured with.
    """

    trunk: RiverPath
    u_shape: UShape
    hanging: HangingValleys
    lake_depth: np.ndarray
    lakes: LakeStats
    hypsometry: HypsometryShift
    settings: Settings


def fit_power_law(distance_m: np.ndarray,
                  elevation_m: np.ndarray) -> tuple[float, float, float, float, float]:
    """Least-squares fit of z = z0 + a·|x − x0|^b to a valley cross-section.

    Started from the lowest sample as origin and the straight line of log(z − z0) against
    log|x − x0|, then all four parameters are fitted (scipy ``least_squares``, a > 0,
    b in ``B_BOUNDS``, x0 within the samples).

    Args:
        distance_m: float64[k] distance of the samples along the section (m).
        elevation_m: float64[k] their elevation (m).

    Returns:
        (b, a in m^(1−b), x0 in m, z0 in m, root-mean-square misfit in m).
    """
    from scipy.optimize import least_squares

    x = np.asarray(distance_m, dtype=np.float64)
    z = np.asarray(elevation_m, dtype=np.float64)
    low = int(np.argmin(z))
    x0, z0 = x[low], z[low]
    d, h = np.abs(x - x0), z - z0
    usable = (d > 0.0) & (h > 0.0)
    b, log_a = np.polyfit(np.log(d[usable]), np.log(h[usable]), 1)
    b = float(np.clip(b, B_BOUNDS[0] * 1.5, B_BOUNDS[1] / 1.5))
    span = x[-1] - x[0]

    def misfit(p: np.ndarray) -> np.ndarray:
        return p[0] + np.exp(p[1]) * np.abs(x - p[3]) ** p[2] - z

    start = np.array([z0, log_a, b, x0])
    lower = np.array([-np.inf, -np.inf, B_BOUNDS[0], x[0] - 1e-9 * span])
    upper = np.array([np.inf, np.inf, B_BOUNDS[1], x[-1] + 1e-9 * span])
    fit = least_squares(misfit, start, bounds=(lower, upper), x_scale="jac")
    z0, log_a, b, x0 = fit.x
    rmse = float(np.sqrt(np.mean(fit.fun**2)))
    return float(b), float(np.exp(log_a)), float(x0), float(z0), rmse


def _valley_window(z: np.ndarray, centre: int) -> slice | None:
    """The samples of a section between its valley sides: out from ``centre`` (the trunk) on
    each side over the finite samples to the highest one (the side's crest), both sides cut at
    the lower crest's height. None when the centre is nodata."""
    if not np.isfinite(z[centre]):
        return None
    left = z[centre::-1]
    right = z[centre:]
    left = left[: _finite_run(left)]
    right = right[: _finite_run(right)]
    cut = min(left.max(), right.max())
    lo = centre - _below(left, cut) + 1
    hi = centre + _below(right, cut)
    return slice(lo, hi)


def _finite_run(values: np.ndarray) -> int:
    """Length of the leading run of finite values."""
    bad = ~np.isfinite(values)
    return int(np.argmax(bad)) if bad.any() else values.size


def _below(values: np.ndarray, cut: float) -> int:
    """Number of leading values ≤ ``cut``."""
    above = values > cut
    return int(np.argmax(above)) if above.any() else values.size


def _trunk_point(trunk: RiverPath, chainage: float) -> tuple[float, float]:
    """Cell coordinates (row, col) of the trunk at ``chainage`` (m), linear between samples."""
    row = np.interp(chainage, trunk.chainage, trunk.rows)
    return float(row), float(np.interp(chainage, trunk.chainage, trunk.cols))


def u_shape_index(elevation: np.ndarray, grid: Grid, trunk: RiverPath,
                  settings: Settings | None = None) -> UShape:
    """Cross-sections of the trunk valley every ``settings.spacing_m`` metres (at the middle of
    equal reaches), each fitted with z = z0 + a·|x − x0|^b (:func:`fit_power_law`).

    A section runs perpendicular to the trunk's direction, taken between the trunk points
    ``half_width_m``/2 upstream and downstream (the valley's direction, not the channel's
    wiggles), out to ``half_width_m`` on each side, sampled every min(dx, dy) metres by
    bilinear interpolation (NaN on nodata and off the map). It is fitted between its valley
    sides (the highest sample on each side, both cut at the lower one) when that relief reaches
    ``min_relief_m`` and ``MIN_SIDE_SAMPLES`` samples lie on each side of the lowest one.
    """
    from scipy import ndimage

    settings = settings or Settings()
    settings.check()
    dx, dy = grid.dx, grid.dy
    step = min(dx, dy)
    count = int(settings.half_width_m // step)
    along = np.arange(-count, count + 1) * step
    values = np.where(grid.valid, elevation, np.nan).astype(np.float64)
    sections = []
    chainages = np.arange(0.5 * settings.spacing_m, trunk.length, settings.spacing_m)
    for chainage in chainages:
        row, col = _trunk_point(trunk, chainage)
        r1, c1 = _trunk_point(trunk, max(chainage - 0.5 * settings.half_width_m, 0.0))
        r2, c2 = _trunk_point(trunk, min(chainage + 0.5 * settings.half_width_m, trunk.length))
        east, south = (c2 - c1) * dx, (r2 - r1) * dy
        norm = np.hypot(east, south)
        if norm == 0.0:
            continue
        rows = row + along * (east / norm) / dy  # normal (−south, east) in (east, south) metres
        cols = col - along * (south / norm) / dx
        z = ndimage.map_coordinates(values, [rows, cols], order=1, mode="constant", cval=np.nan)
        window = _valley_window(z, count)
        if window is None:
            continue
        x, zw = along[window], z[window]
        low = int(np.argmin(zw))
        relief = float(min(zw[0], zw[-1]) - zw[low])
        if relief <= 0.0 or relief < settings.min_relief_m or not (
                MIN_SIDE_SAMPLES <= low < zw.size - MIN_SIDE_SAMPLES):
            continue
        b, a, x0, z0, rmse = fit_power_law(x, zw)
        sections.append(CrossSection(float(chainage), row, col, rows[window], cols[window], x, zw,
                                     b, a, x0, z0, relief, rmse))
    return UShape(tuple(sections), int(chainages.size))


def hanging_steps(
    elevation: np.ndarray, grid: Grid, outlets: np.ndarray, trunk: RiverPath,
    settings: Settings | None = None,
) -> HangingValleys:
    """The tributaries of ``trunk`` and the step of each at its junction.

    On the D8 network of the priority-flooded surface (the trunk's), a tributary is a cell off
    the trunk, outside the filled depressions (across a lake the flow follows the filled
    surface, not a valley), whose receiver is on the trunk and whose drainage area is at least
    ``tributary_fraction`` of the trunk's catchment. Its last reach is traced up from the
    junction, into the donor of largest area, over at most ``reach_m`` metres (length ℓ, at
    least one cell); its step is Δz − S·ℓ with Δz the elevation of the reach's upper end above
    the junction cell and S the trunk's gradient at the junction (least-squares slope of the
    trunk's elevation against chainage within ``reach_m`` of it, or within one diagonal cell
    when that is longer).
    """
    from unerode_cli.analysis.river_kernels import trace_upstream

    settings = settings or Settings()
    settings.check()
    ny, nx = grid.shape
    z = np.asarray(elevation, dtype=np.float64).ravel()
    routing = route(elevation, grid, outlets, "d8")
    receivers = routing.receivers().ravel()
    area = drainage_area(routing).ravel()
    trunk_cells = (np.rint(trunk.rows).astype(np.int64) * nx + np.rint(trunk.cols).astype(np.int64))
    position = np.full(z.size, -1, dtype=np.int64)
    position[trunk_cells] = np.arange(trunk_cells.size)
    min_area = settings.tributary_fraction * float(area[trunk_cells[0]])
    into_trunk = (receivers >= 0) & (position[np.maximum(receivers, 0)] >= 0)
    on_land = fill_depressions(elevation, grid, outlets).ravel() <= z  # not under lake water
    donors = np.flatnonzero(into_trunk & on_land & (position < 0) & (area >= min_area))
    donors = donors[np.argsort(position[receivers[donors]], kind="stable")]
    window = max(settings.reach_m, float(np.hypot(grid.dx, grid.dy)))  # at least two trunk cells
    junctions = []
    for donor in donors:
        junction = int(receivers[donor])
        reach = np.concatenate(([junction], trace_upstream(receivers, area, nx, int(donor), 0.0)))
        r, c = np.divmod(reach, nx)
        length = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(r) * grid.dy, np.diff(c) * grid.dx))))
        last = max(int(np.searchsorted(length, settings.reach_m, side="right")) - 1, 1)
        k = position[junction]
        chainage = float(trunk.chainage[k])
        near = np.abs(trunk.chainage - chainage) <= window
        near[max(k - 1, 0): k + 2] = True  # the junction's neighbours on the trunk at least
        gradient = float(np.polyfit(trunk.chainage[near] - chainage, z[trunk_cells[near]], 1)[0])
        drop = float(z[reach[last]] - z[junction])
        ell = float(length[last])
        junctions.append(Junction(int(r[0]), int(c[0]), chainage, float(area[donor]), r[: last + 1],
                                  c[: last + 1], ell, drop, gradient, drop - gradient * ell))
    return HangingValleys(tuple(junctions), min_area, settings.min_step_m)


def lakes(elevation: np.ndarray, grid: Grid, outlets: np.ndarray,
          min_depth: float = MIN_LAKE_DEPTH) -> tuple[np.ndarray, LakeStats]:
    """The lakes of a bare terrain: water depth (m, float64[ny, nx]) in its depressions filled
    to their spill level towards ``outlets``, and their count, area and volume (lakes deeper
    than ``min_depth`` m somewhere)."""
    depth = water_depth(elevation, grid, outlets)
    return depth, lake_stats(depth, grid, min_depth)


def hypsometry_shift(elevation: np.ndarray, before: np.ndarray | None = None,
                     bins: int = 50) -> HypsometryShift:
    """Hypsometry (metres, ``bins`` bins) of ``elevation`` and of ``before`` (m, NaN on nodata;
    any grid) and the shift of their maximum, mean and integral from before to after."""
    after = hypsometry(elevation, bins, "none")
    return HypsometryShift(after, None if before is None else hypsometry(before, bins, "none"))


def measure_landforms(
    elevation: np.ndarray,
    grid: Grid,
    outlets: np.ndarray,
    before: np.ndarray | None = None,
    settings: Settings | None = None,
) -> Landforms:
    """Every measure of this module on ``elevation`` (m, NaN on nodata), with the hypsometry
    of ``before`` (m) when given.

    Raises:
        ValueError: a bad setting, no outlet, non-finite elevations in the domain, cells that
            cannot drain, or a trunk of a single cell.
    """
    settings = settings or Settings()
    settings.check()
    trunk = auto_river(elevation, grid, outlets, min_area_fraction=settings.trunk_fraction)
    depth, stats = lakes(elevation, grid, outlets, settings.min_lake_depth_m)
    return Landforms(
        trunk=trunk,
        u_shape=u_shape_index(elevation, grid, trunk, settings),
        hanging=hanging_steps(elevation, grid, outlets, trunk, settings),
        lake_depth=depth,
        lakes=stats,
        hypsometry=hypsometry_shift(elevation, before, settings.bins),
        settings=settings,
    )
