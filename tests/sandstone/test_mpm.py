"""MLS-MPM stress (002 §4): static stresses of rocks under their own weight against statics."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from scipy.linalg import polar

from unerode_cli.sandstone import mpm
from unerode_cli.sandstone.layers import GRAVITY, Rock
from unerode_cli.sandstone.mpm import MpmParams, StressSolver, lithostatic_guess
from unerode_cli.sandstone.mpm_kernels import SERIES_LIMIT, cauchy_stress
from unerode_cli.sandstone.particles import Particles
from unerode_cli.sandstone.sampling import Lattice, sample
from unerode_cli.sandstone.scene import parse_scene

SPACING = 0.5
ROCK = Rock()


pytestmark = pytest.mark.usefixtures("one_thread")


def _settled(shape: dict, size: tuple[float, float, float], lithostatic: bool = False,
             substeps: int = 6000) -> tuple[Particles, np.ndarray, StressSolver]:
    lattice = Lattice((0.0, 0.0, 0.0), size, SPACING)
    solid = parse_scene({"domain": {"size": list(size)}, "shape": shape}).shape
    particles = Particles.new(sample(solid, lattice, seed=3), np.zeros(0))
    solver = StressSolver(lattice.mpm_grid(), ROCK, SPACING**3, MpmParams())
    if lithostatic:
        lithostatic_guess(particles, lattice.surface_grid(), ROCK, SPACING)
    relaxation = solver.relax(particles, substeps)
    assert relaxation.converged, relaxation
    return particles, solver.cauchy_stress(particles), solver


def test_corotated_stress_is_hookes_law_for_small_strains() -> None:
    """σ = λ tr(ε) I + 2μ ε for F = I + ε (the J that 002 Eq. 5 drops is second order), and a
    rotation of an unstrained body carries no stress."""
    eps = np.array([[1e-5, 2e-6, 0.0], [2e-6, -3e-6, 1e-6], [0.0, 1e-6, 4e-6]])
    sigma = cauchy_stress((np.eye(3) + eps)[None], ROCK.shear_modulus, ROCK.lame_lambda)[0]
    hooke = ROCK.lame_lambda * np.trace(eps) * np.eye(3) + 2.0 * ROCK.shear_modulus * eps
    np.testing.assert_allclose(sigma, hooke, rtol=1e-4, atol=1e-4 * np.abs(hooke).max())
    c, s = np.cos(0.3), np.sin(0.3)
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    assert np.abs(cauchy_stress(rotation[None], ROCK.shear_modulus, ROCK.lame_lambda)).max() < 1e-3


@pytest.mark.parametrize("strain", [1e-6, 1e-4, 0.3 * SERIES_LIMIT, 3.0 * SERIES_LIMIT, 0.2])
def test_corotated_stress_matches_scipys_polar_decomposition(strain: float) -> None:
    """σ = (2μ(F − R)Fᵀ + λJ(J − 1)I)/J with R from scipy's polar decomposition, on rotated and
    strained F, on both sides of the series' limit (relative 1e-8 of the largest entry)."""
    rng = np.random.default_rng(7)
    c, s = np.cos(0.7), np.sin(0.7)
    rotation = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    deformation = rotation @ (np.eye(3) + strain * rng.uniform(-1.0, 1.0, (20, 3, 3)))
    sigma = cauchy_stress(deformation, ROCK.shear_modulus, ROCK.lame_lambda)
    for f, got in zip(deformation, sigma, strict=True):
        r, _ = polar(f)
        j = np.linalg.det(f)
        tau = 2.0 * ROCK.shear_modulus * (f - r) @ f.T + ROCK.lame_lambda * j * (j - 1.0) * np.eye(3)
        np.testing.assert_allclose(got, tau / j, rtol=0.0, atol=1e-8 * np.abs(tau).max())


def test_relaxation_is_the_same_on_one_and_two_threads(threads, monkeypatch) -> None:
    """Bit for bit: the race-free scatter and the fixed chunks do not depend on the threads."""
    monkeypatch.setattr(mpm, "SERIAL_BELOW", 0)
    shape, size = {"box": {"min": [2, 2, 0], "max": [14, 10, 8]}}, (16.0, 12.0, 12.0)
    results = []
    for count in (1, 2):
        numba.set_num_threads(min(count, numba.config.NUMBA_NUM_THREADS))
        lattice = Lattice((0.0, 0.0, 0.0), size, SPACING)
        solid = parse_scene({"domain": {"size": list(size)}, "shape": shape}).shape
        particles = Particles.new(sample(solid, lattice, seed=3), np.zeros(0))
        lithostatic_guess(particles, lattice.surface_grid(), ROCK, SPACING)
        relaxation = StressSolver(lattice.mpm_grid(), ROCK, SPACING**3, MpmParams()).relax(particles, 60)
        results.append((relaxation, particles))
    (first, a), (second, b) = results
    assert first == second
    for name in ("positions", "velocity", "affine", "deformation", "stress"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def test_free_standing_column_carries_its_weight() -> None:
    """σ_zz = −ρg(H − z), σ_xx = σ_yy = 0 in a free column, within 3 % (relative L2 over the
    interior, away from base and top), from rest (no lithostatic guess)."""
    height = 16.0
    particles, sigma, _ = _settled({"box": {"min": [4, 4, 0], "max": [8, 8, height]}}, (12.0, 12.0, 20.0))
    z = particles.positions[:, 2]
    interior = (z > 4.0) & (z < height - 4.0)
    exact = -ROCK.density * GRAVITY * (height - z[interior])
    norm = np.linalg.norm(exact)
    assert np.linalg.norm(sigma[interior, 2, 2] - exact) / norm < 0.03
    assert np.linalg.norm(sigma[interior, 0, 0]) / norm < 0.03
    assert np.linalg.norm(sigma[interior, 1, 1]) / norm < 0.03


def test_lithostatic_guess_reaches_the_same_static_state() -> None:
    shape, size = {"box": {"min": [4, 4, 0], "max": [8, 8, 16]}}, (12.0, 12.0, 20.0)
    guessed, from_guess, _ = _settled(shape, size, lithostatic=True)
    rested, from_rest, _ = _settled(shape, size)
    difference = np.linalg.norm(from_guess[:, 2, 2] - from_rest[:, 2, 2]) / np.linalg.norm(from_rest[:, 2, 2])
    assert difference < 0.02


def test_cap_loaded_pillar_carries_the_cap() -> None:
    """σ_zz = −(W + ρgA(H − z))/A at sections at least a pillar width below the cap, within 5 %.
    W and the pillar's weight above z are counted from the particles (m = ρ s³ each)."""
    width, top = 4.0, 12.0
    shape = {"union": [{"box": {"min": [8, 8, 0], "max": [12, 12, top]}},
                       {"box": {"min": [4, 4, top], "max": [16, 16, top + 4]}}]}
    particles, sigma, _ = _settled(shape, (20.0, 20.0, 20.0))
    z = particles.positions[:, 2]
    weight = ROCK.density * SPACING**3 * GRAVITY
    area = width * width
    for section in np.arange(2.5, top - width + 0.01, 1.0):
        layer = np.abs(z - section) < 0.5
        load = weight * np.count_nonzero(z > section)
        expected = -load / area
        assert sigma[layer, 2, 2].mean() == pytest.approx(expected, rel=0.05), section


def test_a_wide_layer_bonded_to_its_ground_carries_geostatic_stress() -> None:
    """The interior of a layer 30 m wide and 4 m thick on the ground is in uniaxial strain:
    σ_zz = −ρg(H − z) and σ_xx = σ_yy = ν/(1 − ν)·σ_zz (Jaeger, Cook & Zimmerman 2007, ch. 5),
    each within 3 %, as a frame's first relaxation leaves it (the geostatic start, default
    tolerance). A layer that slid on its base would keep σ_xx ≈ 0."""
    thickness = 4.0
    particles = Particles.new(sample(parse_scene({"domain": {"size": [32.0, 32.0, 8.0]}, "shape": {
        "box": {"min": [1, 1, 0], "max": [31, 31, thickness]}}}).shape,
        Lattice((0.0, 0.0, 0.0), (32.0, 32.0, 8.0), SPACING), seed=3), np.zeros(0))
    lattice = Lattice((0.0, 0.0, 0.0), (32.0, 32.0, 8.0), SPACING)
    solver = StressSolver(lattice.mpm_grid(), ROCK, SPACING**3, MpmParams())
    lithostatic_guess(particles, lattice.surface_grid(), ROCK, SPACING)
    assert solver.relax(particles, MpmParams().settle_substeps).converged
    assert_geostatic(solver.cauchy_stress(particles), particles.positions, thickness)


def assert_geostatic(sigma: np.ndarray, positions: np.ndarray, thickness: float) -> None:
    """The core of a wide layer ``thickness`` m thick (x, y within 4 m of 16 m, z in 1–3 m) is in
    uniaxial strain: σ_zz = −ρg(H − z), σ_xx = σ_yy = ν/(1 − ν)·σ_zz, each within 3 %."""
    x, y, z = positions.T
    core = (np.abs(x - 16.0) < 4.0) & (np.abs(y - 16.0) < 4.0) & (z > 1.0) & (z < 3.0)
    vertical = sigma[core, 2, 2].mean()
    assert vertical == pytest.approx(-ROCK.density * GRAVITY * (thickness - z[core]).mean(), rel=0.03)
    ratio = ROCK.poisson_ratio / (1.0 - ROCK.poisson_ratio)
    assert sigma[core, 0, 0].mean() / vertical == pytest.approx(ratio, rel=0.03)
    assert sigma[core, 1, 1].mean() / vertical == pytest.approx(ratio, rel=0.03)
