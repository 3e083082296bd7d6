"""Adaptive, multi-scale ice transport (001 §5): long steps dt (10–100 y) towards the steady state.

One step of length dt (y), every field on the base grid:

1. local step  δt(x) = min(dt, c / (|ū|/dx + |v̄|/dy))  (y), 001's c·dx/|ū| along one axis, with
   the speeds taken on the faces of the cell (``local_dt``);
2. transport term  T = M − ∇·(ū h)  (m/y, 001 §5), the divergence from
   ``transport.flux_divergence`` (mean face velocity, limited upwind thickness), clamped to
   T ≥ −h/δt, which is 001's T ≥ 0 "outside the glacier" where h = 0 (``transport_rate``);
3. a Gaussian stack T_0 = T, T_1, …, T_n (``gaussian_stack``): T_k is T brought down k times
   (Gaussian smoothing, then 2 × 2 block means) and back up k times (each block's value spread
   over its cells, then Gaussian smoothing), so that every T_k lives on the base grid (001 §4:
   "every level i is a sequence of i downsampling operators followed by i upsampling steps");
4. residuals R_i = T_i − T_{i+1} (i = 0 … n−1) and the stabilised change (m)

       T' = Σ_{i<n} min(f^i·δt_i, dt)·R_i + min(f^n·δt_n, dt)·T_n                  (001 §5)

   with δt_i = min(δt, δt smoothed as level i) (``smoothed_dt``: 001 weighs every level with the
   cell's own δt, which sinks ice divides; see there), each weight at least the one of the level
   below it (``level_weights``: no level may enter with a negative share), (``combine``). The
   coarsest level T_n
   is the last term, with the next
   weight, so that the stack adds up to T (Σ R_i + T_n = T_0): wherever δt = dt as far as the
   coarsest level reaches, the step is exactly the explicit one, T' = dt·T — where the ice is
   slow, and outside the glacier;
5. h(t + dt) = max(0, h + T'), and ice thinner than ``transport.MELT_OUT_THICKNESS`` (1 cm)
   melts out where M < 0 (``transport.melt_out``).

f ∈ [1, 2]: level i is smooth over 2^i cells, where the CFL step is 2^i·δt, and f^i·δt stays
below it (001 sets f = 1.7: larger values make the levels oscillate against each other).

Levels: by default (``level_count``) an axis is halved while it has at least 2·``MIN_LEVEL_CELLS``
cells, so the coarsest level has 4 to 7 cells along the longer axis. The smoothing is a
normalised Gaussian of σ = 1 cell of the level and radius 5 cells (11 taps; 001 §4: σ = 1 cell,
a kernel of ten cells), reflected at closed and open edges, wrapped at periodic ones. The last
block of an odd-sized axis holds one cell and is weighted by the area it covers. Every operator
keeps the area-weighted sum (the volume rate, m³/y) and maps a uniform field onto itself, so
Σ_x T_k = Σ_x T for every k and Σ_x R_i = 0.

Two readings of 001's text, both needed for the scheme to settle with SIA velocities: on the
40 × 40 ice cap of the tests, with dt = 20 y, the cell's own speed in δt blows up within four
steps, and the clamp T ≥ 0 only where h = 0 keeps the volume oscillating 36 % below the explicit
scheme's:

- |ū(x)| in δt is the largest speed on the cell's faces (mean of the two cells), where the
  upwind divergence uses the velocity. With the cell's own speed, an empty cell beside fast ice
  keeps δt = dt and takes a whole dt of inflow at once.
- "Outside the glacier" T ≥ 0 becomes T ≥ −h/δt everywhere: no more melt than the ice there in
  the local step. Otherwise thin ice that the coarse levels spread into the ablation zone returns
  a melt |M|·δt ≫ h that the smoothing spreads back over the glacier, which then never settles.
  For c ≤ 1/3 this clamp never limits the transport, only the melt (a cell sends out at most
  3·c·h/δt, see ``transport``); with δt = dt it does not change the step, since
  max(0, h + dt·T) = h + dt·max(T, −h/dt).

Conservation: the volume changes by Σ_x T' = Σ_i Σ_x w_i·R_i, w_i = min(f^i·δt, dt). Where each
w_i is uniform in space (dt below the CFL step everywhere, or a uniform speed) that is
Σ_i w_i·Σ_x R_i, so with M = 0 and closed or periodic edges the volume is kept to rounding
(before the clip at h = 0). Where δt varies it is not: with Σ_x T = 0,
|Σ_x T'| ≤ Σ_i ½·(max w_i − min w_i)·Σ_x |R_i| (``conservation_bound``), the price 001 pays for
reaching the steady state in few steps. The explicit scheme's steady states are steady states
here too: T = 0 under the ice and T ≤ 0 (clamped to 0) where there is none make every R_i and T'
vanish. The path there differs: on the ice cap of the tests a few margin cells keep ~10 m more
ice for thousands of years (+0.7 % of the volume after 100 steps of 20 y).

Time accuracy: where δt < dt the step takes in only min(f^i·δt_i, dt)/dt of the tendency T —
accumulation included — so fast ice follows a changing climate late. On the 001 Fig. 6 glaciation
(256² of 250 m, the ELA falling 18 m per ky, c = 0.05) the ice volume of dt = 50 y lags that of
dt = 10 y by 9–11 % from 5 to 50 ky and by 56 % at 70 ky, as the ice sheet forms (555 against
1252 km³; 562 with one L-BFGS iteration before and after the finest level's coarse correction);
dt = 20 y lags by 2.4–4 % from 10 to 55 ky and by 36 % at 70 ky (801 against 1254 km³): it
reaches 100, 400 and 800 km³ 0.5, 1.2 and 2.3 ky after dt = 10 y, and dt = 50 y 2.0, 4.2 and
7.4 ky after. No step length between them keeps to 2 % through the take-off, when the volume
doubles every 3.5–5 ky. The reference is steady (rerun after a change of the solver's cycles:
within +0.3…+0.8 % to 70 ky, 1254 against 1252 km³) but lags the ice's own response too: from its
state at 25 ky (21.3 km³), explicit steps at the CFL limit (c = 0.1) with the velocities solved
every year (those of ice under 1 m, films that the coarse levels spread, set to 0) gain 0.84 km³
in 100 y, 0.24 of it in the first 10 y, where 10-year multi-scale steps gain 0.10 km³ and 50-year
ones −0.02 km³. 001 Fig. 11 reports ~1 % for 10–20 y (with c = 0.1)
on valley glaciers, and valley glaciers keep to it here: on a 128² crop of Grindelwald (46 m cells,
the ELA falling from 3300 to 2300 m over 70 ky, c = 0.1) dt = 20, 50 and 100 y stay within 2.1 %
of dt = 10 y in 2-ky means from 10 to 70 ky, though the volume swings by ±4 % every 500–800 y
under a steady ELA (waves of ice down the glaciers) at dt = 10–50 y.
The schemes measured against this one on the same runs (sub-stepped transport with held or
thickness-following velocities, a linearly implicit step, per-body volume budgets) and the
figures that rule each of them out are in ``docs/glacier_time_steps.md``.

Starting from no ice, the first step lays dt·M at once (still ice: δt = dt), and the edge this
leaves at the equilibrium line is steep: on the ice cap of the tests, with SIA velocities, a start
at dt = 50 y blows up within six steps, while growing dt from 10 y by × 1.5 a step up to 50 or
200 y settles. From a steady glacier, steps of up to 200 y follow a change of the ELA.

Pure NumPy and scipy.ndimage, loops over levels only; importing this module loads neither numba
nor scipy.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from unerode_cli.glacier import transport
from unerode_cli.grid import Grid

#: 001 §5: "We set it experimentally to f = 1.7".
F = 1.7
#: An axis is halved while it has at least twice this many cells.
MIN_LEVEL_CELLS = 4
_SIGMA = 1.0  # Gaussian standard deviation (cells of the level), 001 §4
_RADIUS = 5  # Gaussian half-width (cells): 11 taps
_SCIPY_MODES = {"periodic": "wrap", "closed": "reflect", "open": "reflect"}


@dataclass(frozen=True)
class _Axis:
    """One axis of one level: ``counts[j]`` base cells in cell j (``full`` in all but maybe the
    last one); ``starts`` the first cell of each block on the finer level, ``lengths`` their sizes."""

    counts: np.ndarray
    full: float
    starts: np.ndarray
    lengths: np.ndarray


def _axis_levels(n: int, levels: int) -> list[_Axis]:
    """The ``levels + 1`` levels of an axis of n base cells, level 0 first."""
    out = [_Axis(np.ones(n), 1.0, np.arange(n), np.ones(n, dtype=np.intp))]
    for _ in range(levels):
        prev = out[-1]
        size = prev.counts.size
        width = 2 if size >= 2 * MIN_LEVEL_CELLS else 1
        starts = np.arange(0, size, width)
        lengths = np.diff(np.append(starts, size))
        out.append(_Axis(np.add.reduceat(prev.counts, starts), prev.full * width, starts, lengths))
    return out


def level_count(shape: tuple[int, int]) -> int:
    """Default number n of coarser levels for a grid of ``shape`` (ny, nx): how many times the
    longer axis can be halved while it has at least 2·``MIN_LEVEL_CELLS`` cells (8 for 1000 cells,
    3 for 40, 0 below 8)."""
    longest, n = max(shape), 0
    while longest >= 2 * MIN_LEVEL_CELLS:
        longest, n = -(-longest // 2), n + 1
    return n


def _along(vector: np.ndarray, axis: int) -> np.ndarray:
    """A 1-D array shaped to broadcast along ``axis`` of a 2-D one."""
    return vector[:, None] if axis == 0 else vector


def _smooth(a: np.ndarray, axes: tuple[_Axis, _Axis], mode: str) -> np.ndarray:
    """Gaussian smoothing of a level (σ = 1 cell) that keeps Σ counts·a and uniform fields.

    On cells of equal size it is the plain normalised filter G, whose columns sum to 1 with
    reflected or wrapped edges. A short last cell L (area fraction φ < 1) trades with the others
    in proportion to its area: a' = G·a − (1 − φ)·G[:, L]·(a_L − a).
    """
    from scipy import ndimage

    for axis, ax in enumerate(axes):
        smoothed = ndimage.gaussian_filter1d(a, _SIGMA, axis=axis, mode=mode, radius=_RADIUS)
        short = 1.0 - ax.counts[-1] / ax.full
        if short > 0.0:
            unit = np.zeros(ax.counts.size)
            unit[-1] = 1.0
            column = ndimage.gaussian_filter1d(unit, _SIGMA, mode=mode, radius=_RADIUS)
            last = a[-1:, :] if axis == 0 else a[:, -1:]
            smoothed -= short * _along(column, axis) * (last - a)
        a = smoothed
    return a


def _restrict(a: np.ndarray, fine: tuple[_Axis, _Axis], coarse: tuple[_Axis, _Axis]) -> np.ndarray:
    """Area-weighted block means on the coarser level (keeps Σ counts·a)."""
    for axis in (0, 1):
        blocks = np.add.reduceat(a * _along(fine[axis].counts, axis), coarse[axis].starts, axis=axis)
        a = blocks / _along(coarse[axis].counts, axis)
    return a


def _prolong(a: np.ndarray, coarse: tuple[_Axis, _Axis]) -> np.ndarray:
    """Each block's value spread over its cells on the finer level (keeps Σ counts·a)."""
    return np.repeat(np.repeat(a, coarse[0].lengths, axis=0), coarse[1].lengths, axis=1)


def _check_levels(shape: tuple[int, int], levels: int | None) -> int:
    if levels is None:
        return level_count(shape)
    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or levels < 0:
        raise ValueError(f"levels must be None or an integer ≥ 0, got {levels!r}")
    return int(levels)


def _check_boundary(boundary: str) -> str:
    if boundary not in _SCIPY_MODES:
        raise ValueError(f"boundary must be one of {sorted(_SCIPY_MODES)}, got {boundary!r}")
    return _SCIPY_MODES[boundary]


def gaussian_stack(field: np.ndarray, boundary: str = "closed",
                   levels: int | None = None) -> list[np.ndarray]:
    """The Gaussian stack [T_0 = field, T_1, …, T_n] on the base grid (001 §4–5), float64[ny, nx] each.

    T_k: k times (smooth, block means), then k times (spread, smooth). Every T_k has the sum of
    ``field`` and a uniform field is its own stack (to rounding). Units: those of ``field``.

    Args:
        field: float[ny, nx]; not modified.
        boundary: ``"periodic"`` wraps the smoothing, ``"closed"`` and ``"open"`` reflect it.
        levels: n; None: ``level_count(field.shape)``.
    """
    mode = _check_boundary(boundary)
    base = np.array(field, dtype=np.float64)
    if base.ndim != 2:
        raise ValueError(f"the field must be 2-D, got shape {base.shape}")
    n = _check_levels(base.shape, levels)
    grids = list(zip(_axis_levels(base.shape[0], n), _axis_levels(base.shape[1], n), strict=True))
    stack, coarse = [base], base
    for k in range(1, n + 1):
        coarse = _restrict(_smooth(coarse, grids[k - 1], mode), grids[k - 1], grids[k])
        up = coarse
        for j in range(k, 0, -1):
            up = _smooth(_prolong(up, grids[j]), grids[j - 1], mode)
        stack.append(up)
    return stack


def local_dt(u_mean: np.ndarray, v_mean: np.ndarray, grid: Grid, dt: float, c: float = transport.CFL,
             boundary: str = "closed") -> np.ndarray:
    """δt(x) = min(dt, c / (max|ū_face|/dx + max|v̄_face|/dy)) (y), float64[ny, nx] (001 §5).

    The speed on a face is the mean of the two cells' |ū|, and each axis takes the faster of the
    cell's two faces (at the domain edges, the edge cell's own speed; wrapped where ``boundary``
    is ``"periodic"``), so the ice crosses at most a fraction c of a cell in δt through every face
    of the cell, inflow included. δt = dt where the ice is still.

    Args:
        u_mean, v_mean: column-mean velocity at the nodes (m/y).
        grid: cell sizes (m).
        dt: target step (y); c: CFL number (001: 0.1).
        boundary: ``"periodic"``, ``"closed"`` or ``"open"``.
    """
    pad_mode = "wrap" if _check_boundary(boundary) == "wrap" else "edge"
    rate = np.zeros(grid.shape)
    for axis, (velocity, size) in enumerate(((v_mean, grid.dy), (u_mean, grid.dx))):
        speed = np.abs(np.asarray(velocity, dtype=np.float64))
        padded = np.pad(speed, [(1, 1) if a == axis else (0, 0) for a in (0, 1)], mode=pad_mode)
        faces = 0.5 * (np.delete(padded, 0, axis=axis) + np.delete(padded, -1, axis=axis))
        rate += np.maximum(np.delete(faces, 0, axis=axis), np.delete(faces, -1, axis=axis)) / size
    cap = np.divide(c, rate, out=np.full(rate.shape, math.inf), where=rate > 0.0)
    return np.minimum(dt, cap)


def transport_rate(thickness: np.ndarray, u_mean: np.ndarray, v_mean: np.ndarray,
                   mass_balance: float | np.ndarray, grid: Grid, delta_t: np.ndarray,
                   boundary: str = "closed") -> np.ndarray:
    """T = M − ∇·(ū h) (m/y) clamped to T ≥ −h/δt, float64[ny, nx] (001 §5; T ≥ 0 where h = 0).

    Args: as ``step``; ``delta_t``: δt (y, > 0) from ``local_dt``.
    """
    h = np.asarray(thickness, dtype=np.float64)
    t = mass_balance - transport.flux_divergence(h, u_mean, v_mean, grid, boundary)
    return np.maximum(t, -h / delta_t)


def level_weights(delta_t: np.ndarray, dt: float, f: float, levels: int,
                  boundary: str = "closed") -> list[np.ndarray]:
    """[w_0 … w_n] (y): the weights of R_0 … R_{n−1}, then of T_n (001 §5), with
    w_i = max(w_{i−1}, min(f^i·δt_i, dt)), w_0 = δt, δt_i = min(δt, δt smoothed as level i is)
    (``smoothed_dt``).

    Why the running maximum: T' = Σ w_i·R_i = w_0·T_0 + Σ_{i≥1} (w_i − w_{i−1})·T_i, a sum of the
    smoothed rates with weights w_i − w_{i−1}, which must not be negative. 001's weights f^i·δt
    grow with i in every cell; the smoothed δt_i alone may not: a cell of still, thin ice beside
    fast ice keeps δt = dt at level 0 while the levels smoothed over its neighbours take their
    small δt, so w_1 − w_0 ≈ −dt and the smoothed ablation next door (T_1 < 0) became a gain.
    On Grindelwald at 92 m (dt 50 y, 115 ka) one such cell, with no ice and no speed on its
    faces, took 634 m of ice in one step (w_0 = 50 y, w_1 = 6.5 y, T_1 = −12 m/y) and the run
    diverged 10 steps later. The running maximum keeps every weight at or below 001's
    (max_{j≤i} f^j·δt_j ≤ f^i·δt)."""
    weights = (np.minimum(f**i * step, dt) for i, step in enumerate(smoothed_dt(delta_t, levels, boundary)))
    return list(itertools.accumulate(weights, np.maximum))


def smoothed_dt(delta_t: np.ndarray, levels: int, boundary: str = "closed") -> list[np.ndarray]:
    """[δt_0 … δt_n] (y): δt_i = min(δt, the level-i member of δt's Gaussian stack), δt_0 = δt.

    001 §5 weighs every level by f^i·δt(x) with the cell's own δt. A level's residual R_i is
    smooth over ~2^i cells, and a weight that varies over fewer cells than that roughens it:
    where δt peaks along a line — an ice divide, where the speed passes through its minimum —
    the divide's cells take every level's change at a larger weight than their neighbours. On
    the 512² bench ice cap (100 m cells, a dome thinning at 22 m/y) the divide sank 246 m in the
    first 10-year step against ~200 m beside it: a 1-cell trough that the ice then rushed into
    at km/y, and the run diverged within four steps. The smoothed δt takes the peaks off at each
    level's own scale; the minimum with δt keeps every weight at or below 001's, so no cell
    takes a longer step than before (still ice far from fast ice keeps δt = dt)."""
    stack = gaussian_stack(delta_t, boundary, levels)
    return [delta_t] + [np.minimum(delta_t, smooth) for smooth in stack[1:]]


def _residuals(stack: list[np.ndarray]) -> list[np.ndarray]:
    """[R_0 … R_{n−1}, T_n] with R_i = T_i − T_{i+1}; they add up to T_0."""
    return [fine - coarse for fine, coarse in zip(stack[:-1], stack[1:], strict=False)] + [stack[-1]]


def combine(stack: list[np.ndarray], weights: list[np.ndarray]) -> np.ndarray:
    """T' = Σ_{i<n} w_i·R_i + w_n·T_n (001 §5), in the units of T times those of w (m/y·y = m)."""
    return sum((w * r for w, r in zip(weights, _residuals(stack), strict=True)), np.zeros(stack[0].shape))


def conservation_bound(stack: list[np.ndarray], weights: list[np.ndarray]) -> float:
    """Σ_i ½·(max w_i − min w_i)·Σ_x |R_i| (m·cells), R_n = T_n: a bound on |Σ_x T'| when
    Σ_x T = 0, since then every Σ_x R_i = 0 and w_i may be shifted by (max w_i + min w_i)/2."""
    pairs = zip(weights, _residuals(stack), strict=True)
    return float(sum(0.5 * np.ptp(w) * np.abs(r).sum() for w, r in pairs))


def step(thickness: np.ndarray, u_mean: np.ndarray, v_mean: np.ndarray, mass_balance: float | np.ndarray,
         grid: Grid, dt: float, boundary: str = "closed", c: float = transport.CFL, f: float = F,
         *, levels: int | None = None) -> np.ndarray:
    """H(t + dt) = max(0, H + T') with the multi-scale change T' (001 §5), float64[ny, nx] (m).

    Args:
        thickness: H ≥ 0 (m); not modified.
        u_mean, v_mean: column-mean ice velocity ū at the nodes (m/y).
        mass_balance: M (m/y of ice), scalar or raster (``massbalance.mass_balance``).
        grid: cell sizes (m).
        dt: target step (y), ≥ 0; may be far above the CFL step (001: 10–100 y).
        boundary: ``"periodic"``, ``"closed"`` or ``"open"`` (as ``transport.flux_divergence``).
        c: CFL number of the local step δt (001: 0.1), > 0.
        f: step growth from one level to the next coarser one, in [1, 2] (001: 1.7).
        levels: number n of coarser levels; None: ``level_count(grid.shape)``.

    With dt at or below ``transport.max_stable_dt`` this is ``transport.step`` (to rounding).

    Raises:
        ValueError: dt negative or not finite, c ≤ 0, f outside [1, 2], an array of another shape
            than the grid, an unknown boundary or a bad ``levels``.
    """
    if not (dt >= 0 and math.isfinite(dt)):
        raise ValueError(f"the time step must be finite and ≥ 0, got {dt} y")
    if not (c > 0 and math.isfinite(c)):
        raise ValueError(f"the CFL number c must be finite and > 0, got {c}")
    if not 1.0 <= f <= 2.0:
        raise ValueError(f"the level step factor f must be in [1, 2], got {f}")
    _check_boundary(boundary)
    arrays = {"thickness": thickness, "u_mean": u_mean, "v_mean": v_mean}
    if np.ndim(mass_balance):
        arrays["mass_balance"] = mass_balance
    for name, a in arrays.items():
        if np.shape(a) != grid.shape:
            raise ValueError(f"{name} has shape {np.shape(a)}, the grid has {grid.shape}")
    n = _check_levels(grid.shape, levels)
    h = np.asarray(thickness, dtype=np.float64)
    if dt == 0:
        return np.maximum(0.0, h)
    delta_t = local_dt(u_mean, v_mean, grid, dt, c, boundary)
    rate = transport_rate(h, u_mean, v_mean, mass_balance, grid, delta_t, boundary)
    stack = gaussian_stack(rate, boundary, n)
    return transport.melt_out(np.maximum(0.0, h + combine(stack, level_weights(delta_t, dt, f, n, boundary))),
                              mass_balance)

