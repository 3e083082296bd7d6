"""The fast Blatter–Pattyn solve: threads that change no bit, the coarse-grid
correction (multigrid) reaching the single-lattice solution, and its energy stopping rule keeping
every coupled step's energy within 1 % of a converged solve."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.glacier import (
    blatter,
    blatter_energy,
    blatter_preconditioner,
    coupled,
    lbfgs_kernels,
    multigrid_transfers,
)
from unerode_cli.grid import Grid


def _ice_cap(n: int = 40, dx: float = 400.0):
    """A parabolic cap (350 m) on a bumpy massif, ELA below its top: it melts back."""
    y, x = (np.mgrid[0:n, 0:n] + 0.5) / n - 0.5
    r = np.hypot(x, y)
    bed = 800.0 * np.exp(-(r / 0.3) ** 2 / 2) + 40.0 * np.sin(9 * np.pi * x) * np.sin(7 * np.pi * y)
    h = 350.0 * np.clip(1.0 - (r / 0.4) ** 2, 0.0, None)
    return bed, h, Grid.full((n, n), dx)


@pytest.mark.parametrize("periodic", [False, True])
@pytest.mark.parametrize("shape", [(40, 40), (39, 37)])
def test_threaded_energy_gradient_is_bit_identical(periodic, shape):
    bed, h, grid = _ice_cap(40)
    bed, h = bed[:shape[0], :shape[1]].copy(), h[:shape[0], :shape[1]].copy()
    level = blatter._level(bed, h, np.full(shape, 2e4), np.ones(shape, dtype=bool), 400.0, 400.0,
                           blatter.FlowParams(), periodic, 0.0)
    x = 10.0 * np.random.default_rng(3).standard_normal(2 * level.n)
    u, v = blatter_energy.expand(x, level.dof)
    serial = np.full((2, *u.shape), np.nan)  # every node written, zeros included
    threads = np.full((2, *u.shape), np.nan)
    energy = blatter_energy.energy_gradient(u, v, *level.args[1:], *serial)
    assert energy == blatter_energy.energy_gradient_parallel(u, v, *level.args[1:], *threads)
    assert np.array_equal(serial, threads)


def test_threaded_lbfgs_passes_are_bit_identical():
    """The L-BFGS passes and the column solve give the same bits on one thread as on threads
    (their threaded versions, called here on a vector below PARALLEL_MIN_UNKNOWNS)."""
    bed, h, _ = _ice_cap(80, 200.0)
    level = blatter._level(bed, h, np.full(bed.shape, 2e4), np.ones(bed.shape, dtype=bool), 200.0, 200.0,
                           blatter.FlowParams(), False, 0.0)
    size = 2 * level.n
    assert size > 2 * lbfgs_kernels.BLOCK  # several blocks
    rng = np.random.default_rng(11)
    a, b, c, d = (rng.standard_normal(size) for _ in range(4))
    assert lbfgs_kernels.dot(a, b) == lbfgs_kernels._dot_threads(a, b)
    assert lbfgs_kernels.dot(a, b) == pytest.approx(float(a @ b), rel=1e-12)
    y1, y2 = a.copy(), a.copy()
    serial = lbfgs_kernels._add_scaled_dot(y1, 0.3, b, c)
    assert serial == lbfgs_kernels._add_scaled_dot_threads(y2, 0.3, b, c)
    assert np.array_equal(y1, y2) and np.allclose(y1, a + 0.3 * b)
    s1, t1, s2, t2 = (np.empty(size) for _ in range(4))
    assert (lbfgs_kernels.new_pair(a, b, c, d, s1, t1)
            == lbfgs_kernels._new_pair_threads(a, b, c, d, s2, t2))
    assert np.array_equal(s1, a - b) and np.array_equal(t1, c - d) and np.array_equal(s2, s1)
    x = rng.standard_normal(size)
    dof, zeta, c_face, dx, dy, tilt, b_visc, p, sigma = level.args[:9]
    diag, upper = blatter_preconditioner.picard_columns(x, dof, zeta, c_face, dx, dy, tilt, b_visc, p, sigma,
                                                 1e-12, 1e-6, False)
    inv, ratio = blatter_preconditioner.column_factor(diag, upper, level.chains)
    serial = blatter_preconditioner.column_solve_factored(inv, ratio, upper, level.chains, a, np.empty(size))
    threads = np.empty(size)
    blatter_preconditioner._column_solve_threads(inv, ratio, upper, level.chains, a, threads)
    assert np.array_equal(serial, threads)


@pytest.mark.parametrize("periodic", [False, True])
def test_driving_force_is_the_gradient_at_rest(periodic):
    """driving_force is ∇E(0): the gravitational term alone, without the energy's powers."""
    bed, h, grid = _ice_cap(40)
    level = blatter._level(bed, h, np.full(bed.shape, 2e4), np.ones(bed.shape, dtype=bool), 400.0, 400.0,
                           blatter.FlowParams(), periodic, 0.05)
    dof, zeta, _, dx, dy, tilt, _, _, _, rho_g = level.args[:10]
    drive = blatter_energy.driving_force(dof, zeta, dx, dy, tilt, rho_g, periodic, level.n)
    at_rest = level.evaluate(np.zeros(2 * level.n))[1]
    assert np.linalg.norm(at_rest) > 0
    np.testing.assert_allclose(drive, at_rest, rtol=1e-12, atol=1e-12 * np.abs(at_rest).max())


def test_transfer_operators_are_adjoint():
    """restrict_gradient is Pᵀ of prolong: (P y)·g = y·(Pᵀ g), open and periodic, odd sizes."""
    rng = np.random.default_rng(5)
    for periodic, shape in ((False, (33, 40)), (True, (34, 40))):
        bed, h, _ = _ice_cap(40)
        bed, h = bed[:shape[0], :shape[1]], h[:shape[0], :shape[1]]
        fine = blatter._level(bed, h, np.full(shape, 2e4), np.ones(shape, dtype=bool), 400.0, 400.0,
                              blatter.FlowParams(), periodic, 0.0)
        levels = blatter._hierarchy(bed, h, np.full(shape, 2e4), np.ones(shape, dtype=bool), 400.0, 400.0,
                                    blatter.FlowParams(), periodic, 0.0, fine)
        assert len(levels) == 2 and (fine.fy, fine.fx) == (2 if shape[0] >= 32 else 1, 2)
        coarse = levels[1]
        y = rng.standard_normal(2 * coarse.n)
        g = rng.standard_normal(2 * fine.n)
        py = multigrid_transfers.prolong(y, fine.transfer, fine.n)
        ptg = multigrid_transfers.restrict_gradient(g, fine.transfer, coarse.n)
        assert py @ g == pytest.approx(y @ ptg, rel=1e-12)
        # a uniform coarse field prolongs to a uniform field wherever the fine nodes see coarse ones
        ones = multigrid_transfers.prolong(np.ones(2 * coarse.n), fine.transfer, fine.n)
        assert np.all((ones <= 1.0 + 1e-12) & (ones >= 0.0)) and np.median(ones) == 1.0


def test_multigrid_reaches_the_single_lattice_solution(monkeypatch):
    bed, h, grid = _ice_cap()
    params = blatter.FlowParams(n_layers=5)
    multi = blatter.solve(bed, h, grid, params, rtol=1e-5, max_iter=20000)
    monkeypatch.setattr(blatter, "MG_MIN_NODES", 10**6)
    single = blatter.solve(bed, h, grid, params, rtol=1e-5, max_iter=20000)
    assert multi.converged and single.converged
    assert multi.energy == pytest.approx(single.energy, rel=1e-6)
    scale = np.abs(single.u).max()
    assert np.abs(multi.u - single.u).max() < 2e-3 * scale
    assert np.abs(multi.v - single.v).max() < 2e-3 * scale


def test_energy_rule_keeps_every_step_within_one_percent():
    """The coupled steps on a lattice that takes multigrid stop on the energy (an estimated distance
    to its minimum of at most ``FLOW_ENERGY_RTOL``·|E|) as well as on the residual: every step's
    energy stays within 1 % of a converged solve (rtol 1e-5) of its geometry (measured: at most
    0.27 % with 3e-3, 0.03 % with 1e-3)."""
    bed, h, grid = _ice_cap()
    params = coupled.CoupledParams(flow=blatter.FlowParams(n_layers=5), erosion=False)
    state = coupled.GlacierState(bed, h)
    errors, settled = [], 0
    for _ in range(4):
        new, report = coupled.step(state, grid, params, 700.0, 20.0)
        converged = blatter.solve(state.bed, state.thickness, grid, params.flow, rtol=1e-5,
                                  initial=report.flow.lattice, max_iter=20000)
        assert converged.converged and report.flow.converged
        settled += report.flow.residual > params.flow_rtol
        errors.append(abs(report.flow.energy - converged.energy) / abs(converged.energy))
        state = new
    assert max(errors) < 0.01, errors
