"""Blatter–Pattyn ice flow (001 Eq. 7): analytic gradient, tilted slab, sliding laws, symmetry."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from unerode_cli.glacier import blatter, blatter_energy, blatter_preconditioner
from unerode_cli.glacier.lattice import dof_map, ice_columns_with_halo, layer_elevations
from unerode_cli.grid import Grid
from unerode_cli.io.rasters import read_terrain

RHO, G, A, N_GLEN = 910.0, 9.81, 1e-16, 3.0
ALPHA = math.radians(0.5)


def _random_lattice(periodic: bool):
    rng = np.random.default_rng(42)
    ny = nx = 16
    bed = 100.0 * rng.random((ny, nx))
    h = 150.0 + 300.0 * rng.random((ny, nx))
    h[:4, :5] = 0.0  # ice free with a margin
    h[8, 3], h[9, 12] = 2.5, 0.7  # thin ice: collapsed layers (dz_min = 1 m, N = 4)
    zeta = layer_elevations(bed, h, 4, 1.0)  # 5 levels
    c = 800.0 + 400.0 * rng.random((ny, nx))
    c_face = blatter.basal_face_friction(c, h, periodic)
    params = (30.0, 45.0, 0.02, blatter.b_from_glen_a(A), 4.0 / 3.0, 1.5, RHO * G, 1e-8, 1e-4, periodic)
    return rng, h, zeta, c_face, params


@pytest.mark.parametrize("periodic", [True, False])
def test_gradient_matches_central_differences(periodic):
    rng, _, zeta, c_face, params = _random_lattice(periodic)
    u = 30.0 * rng.standard_normal(zeta.shape)
    v = 30.0 * rng.standard_normal(zeta.shape)
    gu, gv = np.empty_like(u), np.empty_like(v)
    blatter_energy.energy_gradient(u, v, zeta, c_face, *params, gu, gv)
    scratch = np.empty_like(u), np.empty_like(v)
    step = 1e-3  # m/y
    fd = np.empty(2 * u.size)
    for idx in range(u.size):
        for comp, field in enumerate((u, v)):
            flat = field.reshape(-1)
            keep = flat[idx]
            flat[idx] = keep + step
            e_plus = blatter_energy.energy_gradient(u, v, zeta, c_face, *params, *scratch)
            flat[idx] = keep - step
            e_minus = blatter_energy.energy_gradient(u, v, zeta, c_face, *params, *scratch)
            flat[idx] = keep
            fd[comp * u.size + idx] = (e_plus - e_minus) / (2 * step)
    analytic = np.concatenate([gu.ravel(), gv.ravel()])
    assert np.linalg.norm(fd - analytic) / np.linalg.norm(analytic) < 1e-5


def test_gradient_of_tied_unknowns_matches_central_differences():
    """The gradient with respect to the unknowns (collapsed levels tied, frozen nodes held)."""
    rng, h, zeta, c_face, params = _random_lattice(True)
    frozen = rng.random(h.shape) < 0.2
    dof, n = dof_map(zeta, ice_columns_with_halo(h, True), frozen)
    assert n < dof.size  # some nodes are tied or held
    x = 30.0 * rng.standard_normal(2 * n)
    work = blatter_energy.workspace(dof)
    _, g = blatter_energy.objective(x, dof, zeta, c_face, *params, work)
    step = 1e-3
    fd = np.empty_like(x)
    for i in range(x.size):
        xp, xm = x.copy(), x.copy()
        xp[i] += step
        xm[i] -= step
        fd[i] = (blatter_energy.objective(xp, dof, zeta, c_face, *params, work)[0]
                 - blatter_energy.objective(xm, dof, zeta, c_face, *params, work)[0]) / (2 * step)
    assert np.linalg.norm(fd - g) / np.linalg.norm(g) < 1e-5


def _slab(dx: float, dy: float, sliding_c: float, sigma: float = 1.5, n_layers: int = 10):
    grid = Grid.full((4, 4), dx, dy)
    params = blatter.FlowParams(glen_a=A, glen_n=N_GLEN, sliding_c=sliding_c, sigma=sigma, rho=RHO,
                                gravity=G, n_layers=n_layers)
    return blatter.solve(np.zeros((4, 4)), np.full((4, 4), 1000.0), grid, params, boundary="periodic",
                         background_slope=ALPHA)


def _sia_profile(z: np.ndarray, h: float = 1000.0) -> np.ndarray:
    tau = RHO * G * math.sin(ALPHA)
    return 2 * A / (N_GLEN + 1) * tau**N_GLEN * (h ** (N_GLEN + 1) - (h - z) ** (N_GLEN + 1))


@pytest.mark.parametrize(("dx", "dy"), [(1000.0, 1000.0), (2000.0, 500.0)])
def test_frozen_slab_matches_the_analytic_simple_shear_profile(dx, dy):
    sol = _slab(dx, dy, math.inf)
    assert sol.converged
    analytic = _sia_profile(np.linspace(0.0, 1000.0, 11))
    assert analytic[-1] == pytest.approx(23.64, abs=0.005)
    u = sol.u[:, 2, 1]
    assert u[-1] == pytest.approx(23.64, rel=0.01)
    assert np.max(np.abs(u - analytic)) / analytic[-1] < 0.02
    assert np.max(np.abs(sol.v)) < 1e-4 * analytic[-1]
    assert np.ptp(sol.u, axis=(1, 2)).max() < 1e-4 * analytic[-1]  # uniform in x and y


@pytest.mark.parametrize(("sigma", "sliding_c"), [(2.0, 1.0e4), (1.5, 2.0e4)])
def test_sliding_slab_slides_at_the_weertman_velocity(sigma, sliding_c):
    """τ_b = C·|u_b|^(σ−1) balances the driving stress ρ g H sinα (along the bed: cos α)."""
    sol = _slab(1000.0, 1000.0, sliding_c, sigma)
    tau_b = RHO * G * 1000.0 * math.sin(ALPHA) * math.cos(ALPHA)
    u_b = (tau_b / sliding_c) ** (1.0 / (sigma - 1.0))
    assert sol.u[0, 0, 0] == pytest.approx(u_b, rel=1e-4)
    deformation = sol.u[-1, 0, 0] - sol.u[0, 0, 0]
    assert deformation == pytest.approx(_sia_profile(np.array([1000.0]))[0], rel=0.01)


def test_transposed_glacier_gives_transposed_velocities():
    """An ice cap on an inclined bed, open edges, dx ≠ dy: swapping the axes swaps u and v."""
    ny, nx, dx, dy = 9, 12, 300.0, 200.0
    y, x = np.mgrid[0:ny, 0:nx]
    bed = 2000.0 - 0.1 * x * dx + 20.0 * np.sin(y)
    r2 = ((x - 5.5) / 4.5) ** 2 + ((y - 4.0) / 3.5) ** 2
    h = np.where(r2 < 1, 200.0 * np.sqrt(np.clip(1 - r2, 0, None)), 0.0)
    params = blatter.FlowParams(sliding_c=2000.0)
    a = blatter.solve(bed, h, Grid.full((ny, nx), dx, dy), params)
    b = blatter.solve(bed.T.copy(), h.T.copy(), Grid.full((nx, ny), dy, dx), params)
    assert a.converged and b.converged
    scale = np.abs(a.u).max()
    assert scale > 1.0  # it flows (m/y)
    assert np.abs(a.u - b.v.transpose(0, 2, 1)).max() < 1e-4 * scale
    assert np.abs(a.v - b.u.transpose(0, 2, 1)).max() < 1e-4 * scale
    assert np.all(a.surface_velocity()[0][h == 0] == 0.0)


def test_warm_start_reaches_the_same_solution():
    cold = _slab(1000.0, 1000.0, 1.0e4, 2.0)
    grid = Grid.full((4, 4), 1000.0)
    params = blatter.FlowParams(glen_a=A, sliding_c=1.05e4, sigma=2.0, rho=RHO, gravity=G)
    kwargs = {"boundary": "periodic", "background_slope": ALPHA}
    bed, h = np.zeros((4, 4)), np.full((4, 4), 1000.0)
    warm = blatter.solve(bed, h, grid, params, initial=(cold.u, cold.v), **kwargs)
    fresh = blatter.solve(bed, h, grid, params, **kwargs)
    assert warm.converged and fresh.converged
    assert np.abs(warm.u - fresh.u).max() < 1e-4 * fresh.u.max()
    again = blatter.solve(bed, h, grid, params, initial=(fresh.u, fresh.v), **kwargs)
    assert again.iterations == 0 and np.array_equal(again.u, fresh.u)


def test_rheology_conventions():
    assert blatter.b_from_glen_a(1e-16) == pytest.approx(2 ** (1 / 3) * 1e-16 ** (-1 / 3), rel=1e-12)
    assert blatter.glen_a_from_b(blatter.b_from_glen_a(3.3e-17)) == pytest.approx(3.3e-17, rel=1e-12)
    assert blatter.glen_a_from_b(blatter.TABLE1_B) == pytest.approx(8.2e-17, rel=0.01)


def test_no_ice_gives_zero_velocity():
    sol = blatter.solve(np.zeros((5, 5)), np.zeros((5, 5)), Grid.full((5, 5), 100.0))
    assert sol.iterations == 0 and not sol.u.any() and not sol.v.any()


def test_column_preconditioner_solves_its_tridiagonal_systems():
    # The random lattice has thin ice with collapsed levels and an ice-free margin.
    rng, h, zeta, c_face, params = _random_lattice(False)
    dof, n = dof_map(zeta, ice_columns_with_halo(h, False), np.zeros(h.shape, dtype=bool))
    x = 30.0 * rng.standard_normal(2 * n)
    dx, dy, tilt, b_visc, p, sigma = params[:6]
    diag, upper = blatter_preconditioner.picard_columns(x, dof, zeta, c_face, dx, dy, tilt, b_visc, p,
                                                 sigma, 1e-12, 1e-6, False)
    chains = blatter_preconditioner.column_chains(dof)
    assert sorted(chains[chains >= 0]) == list(range(n))  # every unknown in exactly one column
    dense = np.diag(diag)
    for half in (0, n):
        for q in range(chains.shape[0] - 1):
            for below, above in zip(chains[q], chains[q + 1], strict=True):
                if below >= 0 and above >= 0:
                    dense[half + below, half + above] = dense[half + above, half + below] = \
                        upper[half + below]
    assert np.all(np.linalg.eigvalsh(dense) > 0)  # positive definite
    r = rng.standard_normal(2 * n)
    out = blatter_preconditioner.column_solve(diag, upper, chains, r, np.empty(2 * n))
    np.testing.assert_allclose(dense @ out, r, rtol=0, atol=1e-9 * np.abs(r).max())


def test_thin_ice_on_steep_terrain_converges():
    # 32 ice columns up to 120 m thick on 30 m cells of the valley sample (slopes up to ~45°),
    # where a diagonal (Jacobi) scaling stalls at a residual of 0.18 after 2000 iterations.
    dem = read_terrain(Path(__file__).parents[2] / "sample_dems" / "valley_utm32n_30m.tif")
    bed = dem.elevation[24:72, 24:72].astype(float)
    thickness = np.clip((bed - 900.0) / 4.0, 0.0, 120.0)
    solution = blatter.solve(bed, thickness, Grid.full(bed.shape, 30.0),
                             blatter.FlowParams(sliding_c=1e5), rtol=0.03, max_iter=1000)
    assert solution.converged and solution.residual <= 0.03
    # 267 when written; 706 since the sliding energy is integrated over the bed's area (a factor
    # √(1 + |∇b|²) of up to 1.4 on these slopes); 212 with the default C = 2e4
    assert solution.iterations < 900


def test_a_checkerboard_velocity_costs_its_analytic_strain_energy():
    """u = A·(−1)^(i+j) on a flat periodic slab with no sliding: at the Gauss points ξ, η = ±1/√3
    the trilinear element has ∂x u = ±2A/(√3·dx), ∂y u = ±2A/(√3·dy) and ∂z u = 0, so
    E = V·(B/p)·(|D|² + ε²)^(p/2) with |D|² = 2·(∂x u² + (∂y u / 2)²). A one-point rule at the
    cells' centres sees no strain rate there (E would be V·(B/p)·ε^p)."""
    n, dx, dy, thickness, amplitude = 8, 40.0, 25.0, 200.0, 3.0
    zeta = layer_elevations(np.zeros((n, n)), np.full((n, n), thickness), 4, 1.0)
    jj, ii = np.mgrid[0:n, 0:n]
    u = np.broadcast_to(amplitude * (-1.0) ** (ii + jj), zeta.shape).copy()
    v = np.zeros_like(u)
    b_visc, p, eps2 = blatter.b_from_glen_a(A), 4.0 / 3.0, 1e-8
    energy = blatter_energy.energy_gradient(u, v, zeta, np.zeros((n, n)), dx, dy, 0.0, b_visc, p, 1.5,
                                            RHO * G, eps2, 1e-4, True, np.empty_like(u), np.empty_like(v))
    ux, uy = 2 * amplitude / (math.sqrt(3) * dx), 2 * amplitude / (math.sqrt(3) * dy)
    d2 = 2.0 * (ux**2 + (uy / 2) ** 2)
    volume = n * dx * n * dy * thickness
    assert energy == pytest.approx(volume * b_visc / p * (d2 + eps2) ** (p / 2), rel=1e-12)
