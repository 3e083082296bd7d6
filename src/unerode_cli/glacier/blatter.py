"""Horizontal ice velocities by the Blatter–Pattyn (first-order) energy (001 §4, Eq. 7).

The velocities (u, v) at the nodes of the terrain-following lattice (``lattice``) minimise

    E(u) = ∫_V (B/p)·|D(u)|^p dV + ∫_Γ (C/σ)·|u_b|_M^σ dS + ρg ∫_V ∇s·u dV          (001 Eq. 7)

discretised in ``blatter_kernels`` (energy and analytic gradient in numba). Here E is
minimised by L-BFGS (``_lbfgs``, with the analytic gradient) over the unknowns of the
ice-covered columns and their one-column halo, warm-started from a previous solution, and
preconditioned column by column: the Picard Hessian restricted to each lattice column is
tridiagonal and solved exactly (a vertical-line relaxation), which removes the stiffness of
thin layers that a diagonal (Jacobi) scaling leaves and on which it stalls.

Rheology convention (Glen's flow law, exponent n, p = 1 + 1/n = 4/3 for n = 3):

- Glen: ε̇_e = A·τ_e^n with the effective (second-invariant) values ε̇_e² = ½ D:D and
  τ_e² = ½ τ:τ, so τ = B_G·ε̇_e^(1/n − 1)·D with B_G = A^(−1/n) (Pa·y^(1/n) for A in
  Pa^(−n)·y^(−1)).
- 001 Eq. 4 writes μ = ½·B·|D|^(p−2), and Eq. 7 (B/p)·|D|^p, with |D| the Frobenius norm
  |D|² = D:D = 2·ε̇_e². Both laws agree when B = 2^((2−p)/2)·B_G = 2^((n−1)/(2n))·A^(−1/n),
  i.e. B = 2^(1/3)·A^(−1/3) for n = 3 (``b_from_glen_a``). This module takes A, as
  ISMIP-HOM does; in a simple-shear slab it gives the textbook
  u(z) = 2A/(n+1)·(ρg sinα)^n·(H^(n+1) − (H − z)^(n+1)).
- 001 Table 1's B = 2.9e5 Pa·y^(1/3) is A = 8.2e-17 Pa⁻³·y⁻¹ in this convention
  (``glen_a_from_b``), close to 78 MPa⁻³·y⁻¹, IGM's default (Jouvet et al. 2022); read as
  B_G = A^(−1/n) it would be A = 4.1e-17 Pa⁻³·y⁻¹.

Sliding (001 Eq. 6): basal shear stress τ_b = C·|u_b|^(σ−1) along −u_b; C in Pa·(y/m)^(σ−1)
(for σ = 2 the linear law τ_b = C·u_b, C = β² of ISMIP-HOM in Pa·y/m); C = ∞ is a frozen bed:
the basal node velocity is held at zero.

Default C (``DEFAULT_SLIDING_C`` = 2e4 Pa·(y/m)^(1/2) for σ = 3/2), calibrated on observed
sliding, not on 001 Table 1. The sliding energy (C/σ)·|u_b|^σ·dS of Eq. 7 must have the units
of the other two terms (Pa·m³/y), so C is in Pa·m^(1−σ)·y^(σ−1); Table 1 prints "500 – ∞
Pa·m^(−σ)·y^σ", which is not that unit (it is off by m/y), so its number cannot be converted.
Read in the consistent unit, C = 500 (the value 1000 used here before) makes the sliding
velocity u_b = (τ_b/C)² = 40 km/y (10 km/y) under τ_b = 100 kPa, the typical basal drag of
valley glaciers (50–150 kPa, Cuffey & Paterson 2010, ch. 8), where measured sliding is 10–100
m/y. Real DEMs showed it: with C = 1000, a 100 × 100 crop of the Grindelwald DEM (46 m) under
an ELA of 2900 m slid at 5 km/y (median surface speed of the ice thicker than 20 m) within 20
y, thin ice on 50–60° walls (τ_b = ρgH·sin α ≈ 70 kPa for H = 10 m) at 5–8 km/y, and the
bed lost up to 250 m in 100 y (abrasion k_e·u^2.02, 001 §6.1). C = 2e4 gives u_b = 25 m/y at
100 kPa, 56 m/y at 150 kPa and 6 m/y at 50 kPa, the range of measured Alpine sliding, and
agrees with IGM's default Weertman law calibrated on Alpine glaciers (τ_b = c·|u_b|^(1/3),
c = 0.0464 MPa·m^(−1/3)·y^(1/3): 10 m/y at 100 kPa, 34 m/y at 150 kPa; Jouvet et al. 2022)
within a factor 2.5 in speed over 100–150 kPa. On the same crop it gives surface speeds of
30 m/y (median), erosion of ~0.5 mm/y under the ice (Herman et al. 2015 measured 0.01–10s
mm/y), and the L-BFGS solves converge in ~50 iterations instead of hitting their cap of 1000.

|u_b|_M² = u_b² + v_b² + (u_b ∂x b + v_b ∂y b)² is the squared velocity along the bed (001 §4.1's
M-norm, read with the bed slope ∂b, which its printed form garbles), and the sliding energy is
integrated over the bed's own area (``blatter_kernels``).

Time units: A in Pa⁻³ per year gives velocities in m/y directly; ρ·g (Pa/m) needs no time
unit, so no seconds enter (ISMIP-HOM's year is 31 556 926 s: A = 1e-16 Pa⁻³·a⁻¹ is 3.17e-24
Pa⁻³·s⁻¹).

Convergence: the iteration stops when the relative residual ‖∇E(u)‖₂ / ‖∇E(0)‖₂ falls below
``rtol``, ∇E(0) being the gravitational driving alone (so the criterion is the unbalanced
force relative to the driving force), or after ``max_iter`` L-BFGS iterations.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from unerode_cli.glacier.lattice import dof_map, ice_columns_with_halo, layer_elevations
from unerode_cli.grid import Grid
from unerode_cli.processes.parameters import ParamSpec


def b_from_glen_a(glen_a: float, n: float = 3.0) -> float:
    """001's B (Pa·y^(1/n), Frobenius-norm convention) from Glen's A (Pa^(−n)·y^(−1)):
    B = 2^((n−1)/(2n))·A^(−1/n)."""
    return 2.0 ** ((n - 1.0) / (2.0 * n)) * glen_a ** (-1.0 / n)


def glen_a_from_b(b: float, n: float = 3.0) -> float:
    """Glen's A (Pa^(−n)·y^(−1)) from 001's B (Pa·y^(1/n)): the inverse of ``b_from_glen_a``."""
    return (b / 2.0 ** ((n - 1.0) / (2.0 * n))) ** (-n)


#: 001 Table 1: B = 2.9e5 Pa·y^(1/3) (n = 3).
TABLE1_B = 2.9e5
#: Default sliding coefficient C (Pa·(y/m)^(1/2) for σ = 3/2): see "Default C" in the module docstring.
DEFAULT_SLIDING_C = 2.0e4

PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("glen_a", "Pa⁻³/y", glen_a_from_b(TABLE1_B), "Glen rate factor A (Pa^-n per year); "
              "default from 001 Table 1 B = 2.9e5 Pa·y^(1/3), B = 2^(1/3)·A^(-1/3)", minimum=0.0,
              symbol="A"),
    ParamSpec("glen_n", "1", 3.0, "Glen exponent n (001: p = 1 + 1/n = 4/3)", minimum=1.0),
    ParamSpec("sliding_c", "Pa·(y/m)^(σ-1)", DEFAULT_SLIDING_C, "sliding coefficient C (001 Eq. 6-7; "
              "default 2e4: 25 m/y of sliding under 100 kPa, calibrated on observed glaciers; "
              "∞ = frozen bed)", minimum=0.0, raster=True, symbol="C"),
    ParamSpec("sigma", "1", 1.5, "sliding exponent σ (001 Table 1: 3/2; 2 = linear law)", minimum=1.0),
    ParamSpec("rho", "kg/m³", 910.0, "ice density ρ (ISMIP-HOM: 910; 001 Table 1: 917)", minimum=0.0),
    ParamSpec("gravity", "m/s²", 9.81, "gravitational acceleration g", minimum=0.0),
    ParamSpec("n_layers", "1", 10, "number of layers N of the lattice (001 §4.2)", minimum=1),
    ParamSpec("dz_min", "m", 1.0, "minimum layer spacing dz_min (001 §4.2)", minimum=1e-3),
)
_SPECS = {spec.name: spec for spec in PARAMETERS}


@dataclass(frozen=True)
class FlowParams:
    """Parameters of the Blatter–Pattyn ice flow (see the module docstring for units).

    ``sliding_c`` may be a raster float[ny, nx] and may hold ``math.inf`` (frozen bed).
    ``strain_rate_reg`` ε (1/y) and ``sliding_reg`` u_ε (m/y) regularise the energy at zero
    strain rate and zero sliding (numerical, not physical).
    """

    glen_a: float = _SPECS["glen_a"].default
    glen_n: float = _SPECS["glen_n"].default
    sliding_c: float | np.ndarray = _SPECS["sliding_c"].default
    sigma: float = _SPECS["sigma"].default
    rho: float = _SPECS["rho"].default
    gravity: float = _SPECS["gravity"].default
    n_layers: int = int(_SPECS["n_layers"].default)
    dz_min: float = _SPECS["dz_min"].default
    strain_rate_reg: float = 1e-6
    sliding_reg: float = 1e-3

    @property
    def b(self) -> float:
        """001's B (Pa·y^(1/n)) for this A and n."""
        return b_from_glen_a(self.glen_a, self.glen_n)

    def validate(self, shape: tuple[int, int]) -> None:
        """Raise ValueError (one sentence) for a value out of range or a raster of another shape."""
        for spec in PARAMETERS:
            value = getattr(self, spec.name)
            if spec.name == "sliding_c":
                if np.ndim(value) and np.shape(value) != shape:
                    raise ValueError(f"parameter sliding_c has shape {np.shape(value)}, the grid has {shape}")
                c = np.asarray(value, dtype=float)
                if np.isnan(c).any() or (c < 0).any():
                    raise ValueError("parameter sliding_c must be ≥ 0 Pa·(y/m)^(σ-1) or inf (frozen bed)")
            else:
                spec.check(value)
        if not (self.strain_rate_reg > 0 and self.sliding_reg > 0):
            raise ValueError("the regularisations strain_rate_reg and sliding_reg must be > 0")


@dataclass
class FlowSolution:
    """Velocities on the lattice and how the minimisation ended.

    Attributes:
        u, v: float64[N+1, ny, nx] node velocities along x and y (m/y); level 0 is the bed.
        zeta: float64[N+1, ny, nx] node elevations (m, without the background tilt).
        thickness: float64[ny, nx] ice thickness H (m) the solution is for.
        iterations: L-BFGS iterations; evaluations: energy+gradient evaluations.
        residual: final ‖∇E‖₂ / ‖∇E(0)‖₂; converged: residual ≤ rtol.
        energy: final E (Pa·m³/y).
    """

    u: np.ndarray
    v: np.ndarray
    zeta: np.ndarray
    thickness: np.ndarray
    iterations: int = 0
    evaluations: int = 0
    residual: float = 0.0
    converged: bool = True
    energy: float = 0.0
    message: str = field(default="")

    def surface_velocity(self) -> tuple[np.ndarray, np.ndarray]:
        """(u_s, v_s) float64[ny, nx] at the ice surface (m/y), 0 where there is no ice."""
        ice = self.thickness > 0
        return np.where(ice, self.u[-1], 0.0), np.where(ice, self.v[-1], 0.0)

    def basal_velocity(self) -> tuple[np.ndarray, np.ndarray]:
        """(u_b, v_b) float64[ny, nx] sliding velocity at the bed (m/y), 0 where there is no ice."""
        ice = self.thickness > 0
        return np.where(ice, self.u[0], 0.0), np.where(ice, self.v[0], 0.0)

    def mean_velocity(self) -> tuple[np.ndarray, np.ndarray]:
        """(ū, v̄) float64[ny, nx]: velocities averaged over the ice column (trapezoidal rule over
        the layers, m/y), the ū of 001 Eq. 1; 0 where there is no ice."""
        dz = np.diff(self.zeta, axis=0)
        h = self.thickness
        safe = np.where(h > 0, h, 1.0)
        um = np.sum(0.5 * (self.u[1:] + self.u[:-1]) * dz, axis=0) / safe
        vm = np.sum(0.5 * (self.v[1:] + self.v[:-1]) * dz, axis=0) / safe
        return np.where(h > 0, um, 0.0), np.where(h > 0, vm, 0.0)


def _corners(field: np.ndarray, periodic: bool) -> tuple[np.ndarray, ...]:
    """The four corner values (00, 01, 10, 11) of every lattice cell column, float[ncy, ncx]."""
    if periodic:
        f01 = np.roll(field, -1, axis=1)
        return field, f01, np.roll(field, -1, axis=0), np.roll(f01, -1, axis=0)
    return field[:-1, :-1], field[:-1, 1:], field[1:, :-1], field[1:, 1:]


def basal_face_friction(sliding_c: np.ndarray, thickness: np.ndarray, periodic: bool) -> np.ndarray:
    """C of each basal face (Pa·(y/m)^(σ−1)): the mean of its finite corner values, 0 where
    the four corners are ice free or all frozen (their velocities are held at zero)."""
    cs = _corners(sliding_c, periodic)
    hs = _corners(thickness, periodic)
    finite = [np.isfinite(c) for c in cs]
    count = sum(f.astype(np.float64) for f in finite)
    total = sum(np.where(f, c, 0.0) for f, c in zip(finite, cs, strict=True))
    ice = sum(hs) > 0
    return np.ascontiguousarray(np.where(ice & (count > 0), total / np.maximum(count, 1.0), 0.0))


#: Number of (step, gradient change) pairs L-BFGS keeps; with the column preconditioner, more
#: pairs barely cut the iterations (5, 8 and 20 took about the same on the bench ice cap).
LBFGS_MEMORY = 8
#: Floors of |D| (1/y) and |u_b| (m/y) in the preconditioner (``picard_columns``) only.
_STRAIN_FLOOR = 1e-6
_SLIDING_FLOOR = 1e-3


class _Objective:
    """∇E of the unknowns, counting the evaluations."""

    def __init__(self, kernel, args: tuple) -> None:
        self.kernel, self.args = kernel, args
        self.evaluations = 0

    def gradient(self, x: np.ndarray) -> np.ndarray:
        self.evaluations += 1
        return self.kernel(x, *self.args)[1]


def _line_search(obj: _Objective, x: np.ndarray, direction: np.ndarray, slope0: float, trial: float):
    """Step α along ``direction`` with |φ'(α)| ≤ 0.9·|φ'(0)| (the strong Wolfe curvature
    condition), φ(α) = E(x + α·direction), found from the directional derivative alone: E is
    convex (p > 1, σ ≥ 1), so φ' increases and its root is the minimum along the line, and the
    search does not depend on the rounding of E (a large sum of terms of both signs), which
    would stall a value-based search well before the gradient is small. Returns (α, ∇E) or
    (None, None) when no such step is found in 40 trials."""
    lo, slope_lo, hi, slope_hi = 0.0, slope0, math.inf, math.nan
    alpha = trial
    for _ in range(40):
        g = obj.gradient(x + alpha * direction)
        slope = float(g @ direction)
        if abs(slope) <= 0.9 * abs(slope0):
            return alpha, g
        if slope < 0:
            lo, slope_lo = alpha, slope
        else:
            hi, slope_hi = alpha, slope
        if math.isinf(hi):
            alpha *= 4.0
        else:  # secant on φ', kept inside the bracket
            secant = lo - slope_lo * (hi - lo) / (slope_hi - slope_lo)
            alpha = min(max(secant, lo + 0.05 * (hi - lo)), hi - 0.05 * (hi - lo))
    return None, None


def _lbfgs(obj: _Objective, x: np.ndarray, direction_of, drive: float, rtol: float, max_iter: int,
           memory: int = LBFGS_MEMORY):
    """Preconditioned L-BFGS on ``obj`` from x; ``direction_of(g, s_hist, y_hist, rho, count,
    newest)`` is the two-loop recursion (``blatter_kernels.lbfgs_direction`` with its
    preconditioner bound). Stops when ‖∇E(x)‖₂ / drive ≤ rtol, after ``max_iter``
    iterations, or when the line search fails from the preconditioned steepest descent.
    Returns (x, ∇E(x), iterations, status): status 0 converged, 1 iteration limit, 2 stalled."""
    s_hist = np.empty((memory, x.size))
    y_hist = np.empty((memory, x.size))
    rho = np.zeros(memory)
    count, newest = 0, memory - 1
    g = obj.gradient(x)
    for it in range(max_iter):
        if float(np.linalg.norm(g)) / drive <= rtol:
            return x, g, it, 0
        direction = direction_of(g, s_hist, y_hist, rho, count, newest)
        slope0 = float(g @ direction)
        step, g_new = _line_search(obj, x, direction, slope0, 1.0) if slope0 < 0 else (None, None)
        if step is None:
            if count == 0:
                return x, g, it, 2
            count = 0  # restart from the preconditioned steepest descent
            continue
        x_new = x + step * direction
        row = (newest + 1) % memory
        np.subtract(x_new, x, out=s_hist[row])
        np.subtract(g_new, g, out=y_hist[row])
        curvature = float(s_hist[row] @ y_hist[row])
        if curvature > 0:
            rho[row] = 1.0 / curvature
            newest, count = row, min(count + 1, memory)
        x, g = x_new, g_new
    status = 0 if float(np.linalg.norm(g)) / drive <= rtol else 1
    return x, g, max_iter, status


def solve(
    bed: np.ndarray,
    thickness: np.ndarray,
    grid: Grid,
    params: FlowParams | None = None,
    *,
    boundary: str = "open",
    background_slope: float = 0.0,
    initial: tuple[np.ndarray, np.ndarray] | None = None,
    rtol: float = 1e-5,
    max_iter: int = 5000,
) -> FlowSolution:
    """Ice velocities minimising the Blatter–Pattyn energy (001 Eq. 7) by L-BFGS.

    Args:
        bed: float[ny, nx] bed elevation b (m).
        thickness: float[ny, nx] ice thickness H ≥ 0 (m); nodata cells of ``grid`` count as
            ice free and their nodes are held at zero velocity.
        grid: cell sizes dx, dy (m; dx ≠ dy allowed) and domain.
        params: rheology, sliding, lattice (``FlowParams``; defaults from 001 Table 1).
        boundary: ``"periodic"`` (the lattice wraps around both axes; give ny = 1 for a
            flowline) or ``"open"`` (stress-free domain edges).
        background_slope: uniform inclination along +x, in RADIANS, added to the geometry:
            the true elevations are b − x·tan(α) and b + H − x·tan(α), so a periodic array can
            hold a tilted slab (ISMIP-HOM).
        initial: (u, v) float[N+1, ny, nx] warm start (m/y), e.g. the previous solution.
        rtol: convergence threshold on ‖∇E‖₂ / ‖∇E(0)‖₂.
        max_iter: maximum L-BFGS iterations.

    Returns:
        A ``FlowSolution`` (velocities zero on nodes without unknowns).
    """
    from unerode_cli.glacier import blatter_kernels as bk

    params = params or FlowParams()
    shape = grid.shape
    if np.shape(bed) != shape or np.shape(thickness) != shape:
        raise ValueError(f"bed {np.shape(bed)} and thickness {np.shape(thickness)} must have the grid's "
                         f"shape {shape}")
    if boundary not in ("periodic", "open"):
        raise ValueError(f"boundary must be 'periodic' or 'open', got {boundary!r}")
    params.validate(shape)
    periodic = boundary == "periodic"
    if not periodic and min(shape) < 2:
        raise ValueError("an open lattice needs at least 2 rows and 2 columns")
    valid = grid.valid
    h = np.where(valid, np.asarray(thickness, dtype=np.float64), 0.0)
    b = np.where(valid, np.asarray(bed, dtype=np.float64), 0.0)
    zeta = layer_elevations(b, h, params.n_layers, params.dz_min)
    c_node = np.broadcast_to(np.asarray(params.sliding_c, dtype=np.float64), shape)
    active = ice_columns_with_halo(h, periodic) & valid
    dof, n = dof_map(zeta, active, np.isinf(c_node))
    solution = FlowSolution(np.zeros_like(zeta), np.zeros_like(zeta), zeta, h)
    if n == 0:
        solution.message = "no ice"
        return solution
    c_face = basal_face_friction(c_node, h, periodic)
    p = 1.0 + 1.0 / params.glen_n
    args = (dof, zeta, c_face, grid.dx, grid.dy, math.tan(background_slope), params.b, p, params.sigma,
            params.rho * params.gravity, params.strain_rate_reg**2, params.sliding_reg**2, periodic)

    x0 = np.zeros(2 * n)
    if initial is not None:
        u0, v0 = (np.asarray(a, dtype=np.float64) for a in initial)
        if u0.shape != zeta.shape or v0.shape != zeta.shape:
            raise ValueError(f"the initial velocities must have the lattice's shape {zeta.shape}")
        has = dof >= 0
        x0[dof[has]] = u0[has]
        x0[n + dof[has]] = v0[has]
    _, g_drive = bk.objective(np.zeros(2 * n), *args)
    drive = float(np.linalg.norm(g_drive))
    if drive == 0.0:
        solution.message = "no driving stress"
        return solution

    x, nit, nfev = x0, 0, 0
    r = float(np.linalg.norm(bk.objective(x0, *args)[1])) / drive
    chains = bk.column_chains(dof)
    out, work = np.empty(2 * n), np.empty(2 * n)
    budget = max_iter
    round_iter, stalls = 50, 0
    while r > rtol and budget > 0 and stalls < 2:
        # The column preconditioner at the current velocities, then L-BFGS; rounds of growing
        # length refresh it as the viscosity settles. A round that stalls (the energy no
        # longer resolves the steps) twice in a row ends the minimisation.
        diag, upper = bk.picard_columns(x, dof, zeta, c_face, grid.dx, grid.dy, args[5], params.b, p,
                                        params.sigma, _STRAIN_FLOOR**2, _SLIDING_FLOOR**2, periodic)
        obj = _Objective(bk.objective, args)

        def direction_of(g, s_hist, y_hist, rho, count, newest, diag=diag, upper=upper):
            return bk.lbfgs_direction(g, s_hist, y_hist, rho, count, newest, diag, upper, chains,
                                      out, work)

        x, g, it, status = _lbfgs(obj, x, direction_of, drive, rtol, min(round_iter, budget))
        nit, nfev, budget = nit + it, nfev + obj.evaluations, budget - it
        r = float(np.linalg.norm(g)) / drive
        stalls = stalls + 1 if status == 2 else 0
        round_iter *= 2
    message = ("converged" if r <= rtol else
               "stalled: rounding of the energy" if stalls else "iteration limit reached")
    energy, g = bk.objective(x, *args)
    solution.u, solution.v = bk.expand(x, dof)
    solution.iterations, solution.evaluations = nit, nfev
    solution.residual = float(np.linalg.norm(g)) / drive
    solution.converged = solution.residual <= rtol
    solution.energy = float(energy)
    solution.message = message
    return solution
