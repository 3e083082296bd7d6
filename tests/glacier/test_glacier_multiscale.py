"""Adaptive multi-scale ice transport (001 §5): stack, exactness, conservation, steady state."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from unerode_cli.glacier import massbalance, multiscale, sia, transport
from unerode_cli.grid import Grid

BOUNDARIES = ["periodic", "closed", "open"]


def _random_state(seed: int, shape=(24, 30)):
    rng = np.random.default_rng(seed)
    h = np.where(rng.random(shape) < 0.3, 0.0, 200.0 * rng.random(shape))  # patchy, with empty cells
    u = 50.0 * rng.standard_normal(shape)
    v = 50.0 * rng.standard_normal(shape)
    return h, u, v


# --- the Gaussian stack -------------------------------------------------------------------------

def test_level_count_halves_the_longer_axis_down_to_a_few_cells():
    assert multiscale.level_count((1000, 1000)) == 8  # 1000 → 500 … 8 → 4
    assert multiscale.level_count((40, 40)) == 3  # 40 → 20 → 10 → 5
    assert multiscale.level_count((3, 200)) == 5  # 200 → … → 7
    assert multiscale.level_count((7, 7)) == 0


@pytest.mark.parametrize("shape", [(37, 53), (3, 200), (101, 9)])
@pytest.mark.parametrize("boundary", BOUNDARIES)
def test_every_level_keeps_the_sum_and_a_uniform_field(shape, boundary):
    field = np.random.default_rng(0).standard_normal(shape)
    stack = multiscale.gaussian_stack(field, boundary)
    assert len(stack) == multiscale.level_count(shape) + 1
    scale = np.abs(field).sum()
    for level in stack:
        assert abs(level.sum() - field.sum()) < 1e-13 * scale
    for level in multiscale.gaussian_stack(np.full(shape, 3.5), boundary):  # odd sizes: short cells
        np.testing.assert_allclose(level, 3.5, rtol=0, atol=1e-13)
    np.testing.assert_array_equal(stack[0], field)


def test_levels_remove_the_fine_scales_and_keep_the_coarse_ones():
    y, x = np.mgrid[0:32, 0:48]
    checkerboard = multiscale.gaussian_stack((-1.0) ** (x + y), "periodic")
    assert [float(np.abs(level).max()) for level in checkerboard[1:]] == [0.0, 0.0, 0.0]
    wave = np.sin(2 * np.pi * x / 48) * np.cos(2 * np.pi * y / 32)  # one period across the domain
    deviation = [np.abs(level - wave).max() for level in multiscale.gaussian_stack(wave, "periodic")]
    assert deviation[1] < 0.07  # 0.067: smoothed once at 1 and once at 2 cells
    assert deviation[1] < deviation[2] < deviation[3] < 1.0  # 0.29, 0.77: 6 × 4 cells at level 3


# --- one step -----------------------------------------------------------------------------------

@pytest.mark.parametrize("boundary", BOUNDARIES)
@pytest.mark.parametrize("fraction", [1.0, 0.3])
def test_below_the_cfl_step_it_is_the_explicit_step(boundary, fraction):
    grid = Grid.full((24, 30), 100.0, 60.0)
    h, u, v = _random_state(2)
    m = np.random.default_rng(3).uniform(-30.0, 2.0, h.shape)  # strong melt: the clip at 0 acts
    dt = fraction * transport.max_stable_dt(u, v, grid)
    np.testing.assert_array_equal(multiscale.local_dt(u, v, grid, dt, boundary=boundary), dt)
    explicit = transport.step(h, u, v, m, grid, dt, boundary)
    assert (explicit == 0).sum() > 50 and (explicit > 0).sum() > 300
    new = multiscale.step(h, u, v, m, grid, dt, boundary)
    np.testing.assert_allclose(new, explicit, rtol=0, atol=1e-12 * h.max())


def test_still_ice_takes_the_whole_step_and_fast_ice_a_fraction():
    grid = Grid.full((16, 16), 100.0)
    u = np.zeros((16, 16))
    u[:, 8] = 40.0  # one fast column: faces of columns 7–9 move, the rest is still
    delta_t = multiscale.local_dt(u, np.zeros_like(u), grid, 50.0)
    np.testing.assert_array_equal(delta_t[:, :7], 50.0)
    np.testing.assert_allclose(delta_t[:, 7:10], 0.1 * 100.0 / 20.0)  # face speed (40 + 0)/2
    h = np.full((16, 16), 100.0)
    m = np.where(u > 0, 0.0, 1.5)
    new = multiscale.step(h, u, np.zeros_like(u), m, grid, 50.0, "periodic")
    far = np.r_[0:4, 13:16]  # beyond the smoothing of the fast column's levels: explicit, dt = 50 y
    np.testing.assert_allclose(new[:, far], 100.0 + 50.0 * 1.5, rtol=1e-12)


def test_level_weights_take_the_peak_of_an_ice_divide_off_and_never_exceed_001s():
    """An ice divide: the speed passes through 0 along a column, so δt peaks there over a few
    cells. 001's weights f^i·δt(x) give the divide's cells the coarse levels' change at up to
    twice the weight of cells 4 columns away; the smoothed δt_i (``smoothed_dt``) makes the
    coarse weights nearly even across the divide, and no weight is above 001's."""
    grid = Grid.full((64, 64), 100.0)
    x = np.arange(64) - 31.5
    u = np.broadcast_to(2.5 * x, (64, 64)).copy()   # m/y, a divide between columns 31 and 32
    v = np.full((64, 64), 10.0)
    delta_t = multiscale.local_dt(u, v, grid, 10.0, boundary="closed")
    n = multiscale.level_count(grid.shape)
    ours = multiscale.level_weights(delta_t, 10.0, multiscale.F, n)
    paper = [np.minimum(multiscale.F**i * delta_t, 10.0) for i in range(n + 1)]
    row = 32
    for level in (3, 4):
        peak = paper[level][row, 30:34].max() / paper[level][row, 26:38].min()
        assert peak > 1.6                                              # 001: a sharp ridge
        assert ours[level][row, 30:34].max() / ours[level][row, 26:38].min() < 1.15
    for w_ours, w_paper in zip(ours, paper, strict=True):
        assert np.all(w_ours <= w_paper + 1e-12)
    np.testing.assert_array_equal(ours[0], paper[0])


def test_a_still_empty_cell_beside_fast_thinning_ice_gains_only_its_mass_balance():
    """A cell with no ice and no speed on its faces keeps δt = dt, while the levels smoothed
    over it take the small δt of the fast ice next door. Its levels must not enter with
    negative shares (w_i < w_{i−1}): then the smoothed thinning of its neighbours (T_1 < 0)
    turned into a gain of hundreds of metres (Grindelwald at 92 m: 634 m in one 50-year step).
    With the weights non-decreasing level by level, the still cell gains dt·M, the explicit
    step of its own mass balance."""
    grid = Grid.full((32, 32), 92.0)
    h = np.zeros((32, 32))
    u = np.zeros((32, 32))
    h[6:19, 6:27] = 160.0
    u[6:19, 6:27] = 1600.0              # a fast, thick tongue, thinning (melt)
    h[11:14, 15:18] = u[11:14, 15:18] = 0.0  # a still, empty 3 × 3 rock knob in it
    m = np.where(h > 0, -40.0, 1.9)     # snow on the knob, 1.9 m/y
    dt = 50.0
    delta_t = multiscale.local_dt(u, np.zeros_like(u), grid, dt, boundary="open")
    still = (12, 16)                    # the knob's centre: its faces do not move
    assert delta_t[still] == dt
    weights = multiscale.level_weights(delta_t, dt, multiscale.F, multiscale.level_count(grid.shape), "open")
    for finer, coarser in zip(weights[:-1], weights[1:], strict=True):
        assert np.all(coarser >= finer)
    new = multiscale.step(h, u, np.zeros_like(u), m, grid, dt, "open")
    assert new[still] == pytest.approx(dt * 1.9, rel=1e-9)


@pytest.mark.slow
def test_the_512_bench_ice_cap_melts_back_without_a_trough_at_its_divide():
    """The bench ice cap at 512² (100 m cells, ``bench/bench_glacier.py``), a dome thinning at
    ~22 m/y under an ELA of 1100 m: with 001's weights its divide sank 246 m in the first 10-year
    step, 40 m more than beside it, and the ice rushed into that trough at 4.6 km/y by the third
    step (diverged at the fourth). With the smoothed weights 12 steps melt it back smoothly:
    the volume falls every step, the fastest ice slows (273 → 14 m/y)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
    import bench_glacier as cap
    from unerode_cli.glacier import coupled

    state, grid, params = cap._ice_cap(512)
    volumes, speeds = [], []
    for _ in range(6):
        state, report = coupled.step(state, grid, params, cap.COUPLED_ELA, 10.0)
        volumes.append(report.volume)
        speeds.append(report.flow.max_speed())
    assert np.all(np.diff(volumes) < 0)
    assert max(speeds) < 300.0 and speeds[-1] < 120.0
    assert state.thickness.max() < 600.0


def test_levels_zero_is_the_locally_adaptive_explicit_step():
    grid = Grid.full((24, 30), 100.0)
    h, u, v = _random_state(4)
    dt = 30.0 * transport.max_stable_dt(u, v, grid)
    delta_t = multiscale.local_dt(u, v, grid, dt)
    rate = multiscale.transport_rate(h, u, v, 0.5, grid, delta_t)
    new = multiscale.step(h, u, v, 0.5, grid, dt, levels=0)
    np.testing.assert_allclose(new, np.maximum(0.0, h + delta_t * rate), rtol=1e-14, atol=1e-12)


def test_inputs_are_not_modified_and_the_result_is_non_negative():
    grid = Grid.full((24, 30), 100.0)
    h, u, v = _random_state(5)
    m = np.full(h.shape, -3.0)
    copies = [a.copy() for a in (h, u, v, m)]
    new = multiscale.step(h, u, v, m, grid, 200.0)
    for a, b in zip((h, u, v, m), copies, strict=True):
        np.testing.assert_array_equal(a, b)
    assert new.dtype == np.float64 and new.shape == h.shape and new.min() >= 0.0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"dt": -1.0}, "time step"),
        ({"dt": float("nan")}, "time step"),
        ({"f": 0.9}, r"f must be in \[1, 2\]"),
        ({"f": 2.5}, r"f must be in \[1, 2\]"),
        ({"c": 0.0}, "CFL number"),
        ({"boundary": "reflecting"}, "boundary must be one of"),
        ({"thickness": np.zeros((5, 5))}, "thickness has shape"),
        ({"u_mean": np.zeros((6, 5))}, "u_mean has shape"),
        ({"mass_balance": np.zeros((3,))}, "mass_balance has shape"),
        ({"levels": -1}, "levels must be"),
        ({"levels": 2.5}, "levels must be"),
    ],
)
def test_bad_arguments_raise_one_sentence(kwargs, message):
    zeros = np.zeros((6, 6))
    args = {"thickness": zeros, "u_mean": zeros, "v_mean": zeros, "mass_balance": 0.0,
            "grid": Grid.full((6, 6), 10.0), "dt": 10.0} | kwargs
    with pytest.raises(ValueError, match=message) as info:
        multiscale.step(**args)
    text = str(info.value)
    assert text.count(". ") == 0 and "\n" not in text


def test_importing_it_loads_neither_numba_nor_scipy():
    probe = ("import sys, unerode_cli.glacier.multiscale; "
             "print(sorted(m for m in ('numba', 'scipy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert out.stdout.strip() == "[]", out.stderr


# --- conservation -------------------------------------------------------------------------------

@pytest.mark.parametrize("boundary", ["periodic", "closed"])
def test_volume_is_kept_at_fifty_times_the_cfl_step_when_the_speed_is_uniform(boundary):
    """|ū| uniform (directions alternate in blocks), M = 0: every level's weight is uniform, so
    only the rounding changes the volume, while the step is 50 times the explicit limit (10 steps,
    before the thinning cells reach 0)."""
    shape = (32, 40)
    grid = Grid.full(shape, 100.0, 80.0)
    y, x = np.mgrid[0:shape[0], 0:shape[1]]
    u = np.where((x // 5 + y // 7) % 2 == 0, 30.0, -30.0)
    v = np.where((x // 6) % 2 == 0, 20.0, -20.0)
    h = 1000.0 + 200.0 * np.sin(x / 4.0) * np.cos(y / 6.0)
    dt = 50.0 * transport.max_stable_dt(u, v, grid)
    delta_t = multiscale.local_dt(u, v, grid, dt, boundary=boundary)
    np.testing.assert_allclose(delta_t, dt / 50.0, rtol=1e-15)
    volume = h.sum()
    for _ in range(10):
        change = multiscale.combine(
            multiscale.gaussian_stack(multiscale.transport_rate(h, u, v, 0.0, grid, delta_t, boundary),
                                      boundary),
            multiscale.level_weights(delta_t, dt, multiscale.F, multiscale.level_count(shape)))
        assert (h + change).min() > 0.0  # no clip at 0
        new = multiscale.step(h, u, v, 0.0, grid, dt, boundary)
        np.testing.assert_allclose(new, h + change, rtol=1e-15, atol=0)
        assert np.abs(change).max() > 50.0  # T' is large: 90 to 150 m a step
        h = new
    assert abs(h.sum() - volume) / volume < 1e-13


def test_volume_change_stays_under_the_bound_when_the_speed_varies():
    """Random speeds, M = 0, closed edges, dt = 50 × CFL: Σ_x T = 0 and every level keeps it, so
    |Σ_x T'| ≤ Σ_i ½·(max w_i − min w_i)·Σ_x|R_i|. The scheme does not conserve here: measured
    ΔV = +7.4e-4 of the volume in one step, 1.3 % of Σ_x|T'|, 0.0066 of the bound."""
    grid = Grid.full((24, 30), 100.0, 60.0)
    h, u, v = _random_state(6)
    h += 50.0
    dt = 50.0 * transport.max_stable_dt(u, v, grid)
    delta_t = multiscale.local_dt(u, v, grid, dt)
    rate = multiscale.transport_rate(h, u, v, 0.0, grid, delta_t)
    np.testing.assert_array_equal(rate, -transport.flux_divergence(h, u, v, grid))  # c ≤ 1/3: no clamp
    assert abs(rate.sum()) < 1e-12 * np.abs(rate).sum()
    stack = multiscale.gaussian_stack(rate)
    for level in stack:
        assert abs(level.sum()) < 1e-12 * np.abs(rate).sum()
    weights = multiscale.level_weights(delta_t, dt, multiscale.F, len(stack) - 1)
    change = multiscale.combine(stack, weights)
    bound = multiscale.conservation_bound(stack, weights)
    assert (h + change).min() > 0.0  # no clip at 0
    assert abs(change.sum()) <= bound
    assert 1e-4 < abs(change.sum()) / h.sum() < 1e-3


# --- steady state against the explicit scheme ---------------------------------------------------

GLEN_A = 1.0e-16  # Pa⁻³/y
ELA = 2200.0  # m


def _ice_cap(n: int, dx: float):
    """A round mountain, 1000 m to 3000 m over a domain of n × n cells of dx (m), and the SIA
    velocity and mass balance (ELA 2200 m, β = 0.01/y, p_max = 2 m/y) of a thickness."""
    grid = Grid.full((n, n), dx)
    y, x = (np.mgrid[0:n, 0:n] - (n - 1) / 2) * dx
    bed = 1000.0 + 2000.0 * np.exp(-((np.hypot(x, y) / (0.225 * n * dx)) ** 2))

    def forcing(h):
        flow = sia.velocity(bed, h, grid, GLEN_A, boundary="open")
        return flow.u_mean, flow.v_mean, massbalance.mass_balance(bed + h, ELA)

    return grid, forcing


def _run(step, forcing, shape, duration):
    """Volumes (m·cells) after each step of ``step(k, h, u, v, m) -> (h, dt)`` until ``duration``
    (y), from no ice, and the wall time (s)."""
    h, t, volumes = np.zeros(shape), 0.0, []
    start = time.perf_counter()
    while t < duration:
        h, dt = step(len(volumes), h, *forcing(h))
        t += dt
        volumes.append(h.sum())
    return np.array(volumes), time.perf_counter() - start


def _steps_to_stay_within(volumes, target, tolerance):
    outside = np.flatnonzero(np.abs(volumes - target) > tolerance * target)
    return 1 if outside.size == 0 else int(outside[-1]) + 2


@pytest.mark.parametrize(
    ("n", "dx", "dt", "explicit_years", "multiscale_steps", "min_speedup"),
    [
        (40, 300.0, 20.0, 600.0, 100, 5),
        pytest.param(80, 150.0, 50.0, 600.0, 80, 10, marks=pytest.mark.slow),
    ],
)
def test_equilibrium_volume_matches_the_explicit_scheme(n, dx, dt, explicit_years, multiscale_steps,
                                                        min_speedup):
    """SIA ice cap grown from no ice, velocity and mass balance recomputed every step.

    Explicit: ``transport.step`` at ``transport.max_stable_dt`` (c = 0.1, ≤ 1 y). Multi-scale: dt,
    grown from 10 y by × 1.5 a step (a cold start at 50 y blows up with SIA). Measured (wall
    times not asserted; a multi-scale step costs ~5 explicit ones here, where the velocity is
    cheap):

    - 40 × 40, 300 m, dt = 20 y: explicit 1622 steps to 600 y, 0.9287 km³, within 2 % from step
      174, 1.0 s; multi-scale 101 steps, 0.9356 km³ (+0.74 %), within 2 % from step 17, 0.2 s;
    - 80 × 80, 150 m, dt = 50 y: explicit 3034 steps, 0.9862 km³, within 2 % from step 309,
      1.7 s; multi-scale 83 steps, 0.9858 km³ (−0.05 %), within 2 % from step 14, 0.2 s.
    """
    grid, forcing = _ice_cap(n, dx)

    def explicit(k, h, u, v, m):
        dt_cfl = min(transport.max_stable_dt(u, v, grid), 1.0)
        return transport.step(h, u, v, m, grid, dt_cfl), dt_cfl

    def adaptive(k, h, u, v, m):
        step_dt = min(dt, 10.0 * 1.5**k)
        return multiscale.step(h, u, v, m, grid, step_dt), step_dt

    ex_volumes, ex_wall = _run(explicit, forcing, grid.shape, explicit_years)
    ms_volumes, ms_wall = _run(adaptive, forcing, grid.shape, multiscale_steps * dt)
    equilibrium = ex_volumes[-1]
    assert abs(ex_volumes[-1] - ex_volumes[int(0.8 * len(ex_volumes))]) < 1e-4 * equilibrium  # steady
    assert abs(ms_volumes[-1] - ms_volumes[-11]) < 2e-3 * ms_volumes[-1]  # settled
    assert ms_volumes[-1] == pytest.approx(equilibrium, rel=0.02)
    ex_steps = _steps_to_stay_within(ex_volumes, equilibrium, 0.02)
    ms_steps = _steps_to_stay_within(ms_volumes, equilibrium, 0.02)
    assert ms_steps * min_speedup <= ex_steps, (ex_steps, ms_steps, ex_wall, ms_wall)
    assert len(ms_volumes) * 10 <= len(ex_volumes)


def test_no_film_of_ice_is_left_below_the_equilibrium_line():
    """The coarse levels spread a glacier's change onto the bare ground around it; below the ELA
    (M < 0) what is left thinner than ``transport.MELT_OUT_THICKNESS`` melts out, while thin ice
    where M ≥ 0 stays (snow, or ice only the flow moves). A 12 × 12 glacier moving at 60 m/y in
    the middle of a 48² map of 50 m cells, melting at 1 m/y: without the melt-out the step left
    ice of 1e-16–1e-2 m on many bare cells (measured: the film cells of the first step)."""
    grid = Grid.full((48, 48), 50.0)
    h = np.zeros((48, 48))
    h[18:30, 18:30] = 150.0
    u = np.where(h > 0, 60.0, 0.0)
    v = np.zeros_like(u)
    melt = np.full(h.shape, -1.0)
    raw = np.maximum(0.0, h + multiscale.combine(
        multiscale.gaussian_stack(multiscale.transport_rate(h, u, v, melt, grid, multiscale.local_dt(
            u, v, grid, 50.0, boundary="open"), "open"), "open"),
        multiscale.level_weights(multiscale.local_dt(u, v, grid, 50.0, boundary="open"), 50.0, multiscale.F,
                                 multiscale.level_count(grid.shape), "open")))
    films = (raw > 0) & (raw < transport.MELT_OUT_THICKNESS)
    assert films.sum() >= 20                     # what the coarse levels leave on the bare ground
    new = multiscale.step(h, u, v, melt, grid, 50.0, "open")
    assert not ((new > 0) & (new < transport.MELT_OUT_THICKNESS)).any()
    np.testing.assert_array_equal(new[~films], raw[~films])
    assert (raw - new).sum() * grid.cell_area < 1e-2 * films.sum() * grid.cell_area  # < 1 cm a cell
    snow = multiscale.step(h, u, v, np.full(h.shape, 0.0), grid, 50.0, "open")
    assert ((snow > 0) & (snow < transport.MELT_OUT_THICKNESS)).any()  # kept where M = 0
    np.testing.assert_array_equal(transport.melt_out(snow, 0.0), snow)
    assert transport.melt_out(np.array([0.005, 0.02, 0.005]), np.array([-1.0, -1.0, 0.0])).tolist() == [
        0.0, 0.02, 0.005]
