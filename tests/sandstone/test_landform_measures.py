"""The landform measures on voxel shapes whose answers are known: a box arch (flat intrados, rise
0), a half-cylinder intrados (rise R(1 − √3/2)), a bridge resting on one support only, a column
with a neck of known width (narrowed from every side or from one), a wall with four openings
between pillars, and recesses with a flat and a half-circle roof."""

from __future__ import annotations

import math

import numpy as np
import pytest

from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.landform_measures import (
    RISE_WINDOW,
    measure_alcove,
    measure_arcade,
    measure_arch,
    measure_hoodoo,
    openings,
    voxelise,
)


def _centres(n: int, h: float) -> np.ndarray:
    return (np.arange(n) + 0.5) * h


def _fin(h: float, nx: int = 120, ny: int = 10, nz: int = 80) -> np.ndarray:
    """A fin along x: cells 10 ≤ i < nx − 10, 2 ≤ j < 8, all heights below 60 cells."""
    rock = np.zeros((nx, ny, nz), dtype=bool)
    rock[10:nx - 10, 2:8, :60] = True
    return rock


def _windowed_rise(profile, span: float) -> float:
    """The rise (m) of the roof ``profile(s)`` (m, s in [0, span]) as the measures average it."""
    offsets = np.linspace(-RISE_WINDOW, RISE_WINDOW, 9) * span

    def at(share: float) -> float:
        return float(np.mean(profile(share * span + offsets)))

    return at(0.5) - 0.5 * (at(0.25) + at(0.75))


def test_voxelise_marks_the_cells_of_particles() -> None:
    """Three particles, two in one cell: two cells of 0.5 m marked, the others not."""
    grid = Grid3D((0.0, 0.0, 0.0), 0.5, (4, 4, 4))
    rock = voxelise(np.array([[0.1, 0.1, 0.1], [0.2, 0.3, 0.4], [1.9, 1.1, 0.6]]), grid)
    assert rock.sum() == 2
    assert rock[0, 0, 0] and rock[3, 2, 1]


def test_a_box_arch_has_a_flat_intrados() -> None:
    """An opening 40 × 20 cells of 0.5 m (span 20 m, 10 m high) in a fin 50 m long and 30 m high:
    one opening of 200 m², intrados 10 m at mid-span and quarter-spans (rise 0), a bridge 20 m
    thick joined to both supports across the whole span."""
    h = 0.5
    rock = _fin(h)
    rock[40:80, :, :20] = False
    arch = measure_arch(rock, h)
    assert arch.openings == 1
    assert arch.area == pytest.approx(200.0, abs=1e-9)
    assert arch.span == pytest.approx(20.0, abs=1e-9)
    assert arch.mid == pytest.approx(10.0, abs=1e-9)
    assert arch.rise == pytest.approx(0.0, abs=1e-9)
    assert arch.bridge_thickness == pytest.approx(20.0, abs=1e-9)
    assert arch.joined and arch.continuous


def test_a_half_cylinder_intrados_rises_by_its_analytic_rise() -> None:
    """A half-cylinder opening of radius R = 10 m (cells of 0.25 m) springing from the ground:
    its rise is R(1 − √3/2) = 1.34 m (1.28 m averaged over the measure's windows), within a
    tenth of a cell; the span is 2R within two cells, mid-span height R within a cell."""
    h, radius = 0.25, 10.0
    rock = _fin(h, nx=120, nz=80)
    x, z = np.meshgrid(_centres(120, h) - 15.0, _centres(80, h), indexing="ij")
    rock[(x**2 + z**2 < radius**2)[:, None, :].repeat(10, axis=1)] = False
    arch = measure_arch(rock, h)
    expected = _windowed_rise(lambda s: np.sqrt(np.maximum(0.0, radius**2 - (s - radius) ** 2)), 2 * radius)
    assert expected == pytest.approx(radius * (1 - math.sqrt(3) / 2), abs=0.07)
    assert arch.openings == 1
    assert arch.span == pytest.approx(2 * radius, abs=2 * h)
    assert arch.mid == pytest.approx(radius, abs=h)
    assert arch.rise == pytest.approx(expected, abs=0.1 * h + 0.05)
    assert arch.rise_cells == pytest.approx(arch.rise / h, rel=1e-12)
    assert arch.joined and arch.continuous


def test_a_bridge_on_one_support_is_not_joined() -> None:
    """Two pillars and a bridge over them that touches the west pillar and passes beside the east
    one (a cell of air between them along y): one opening in projection, its bridge not joined."""
    rock = np.zeros((80, 10, 60), dtype=bool)
    rock[5:20, 2:8, :50] = True
    rock[60:75, 2:4, :50] = True
    rock[15:65, 5:8, 40:50] = True
    arch = measure_arch(rock, 0.5)
    assert arch.openings == 1
    assert arch.span == pytest.approx(20.0, abs=1e-9)
    assert not arch.joined


def test_notches_open_to_the_sky_or_the_ends_are_not_openings() -> None:
    """A slot from the top, a notch at the west end and a one-pixel hole (under ``min_cells``):
    no opening; a 2 × 2 hole in the middle: one."""
    rock = _fin(0.5)
    rock[50:55, :, 30:] = False
    rock[:12, :, 5:10] = False
    rock[80, :, 20] = False
    assert openings(rock, min_cells=2)[1] == 0
    rock[90:92, :, 40:42] = False
    assert openings(rock, min_cells=2)[1] == 1


@pytest.mark.parametrize("sides, expected", [
    ("every", (3.0, 3.0, 2.0, 2.0)),
    ("west", (6.0, 0.0, 0.0, 0.0)),
])
def test_a_column_with_a_neck(sides: str, expected: tuple[float, ...]) -> None:
    """A column 10 × 10 m (cells of 0.5 m), 30 m high, cap above 24 m; from 10 to 14 m it is
    cut to 4 m along x and 6 m along y, centred (from every side) or to 4 m along x from the
    west only: the neck is at 10–14 m, 4 m and 6 m (or 10 m) wide, ratios 0.4 and 0.6 (1.0),
    and its edges retreat as cut."""
    h = 0.5
    rock = np.zeros((24, 24, 64), dtype=bool)
    rock[2:22, 2:22, :60] = True
    rock[2:22, 2:22, 20:28] = False
    if sides == "every":
        rock[8:16, 6:18, 20:28] = True
    else:
        rock[14:22, 2:22, 20:28] = True
    hoodoo = measure_hoodoo(rock, h, cap_base=24.0)
    assert hoodoo.cap_x == pytest.approx(10.0) and hoodoo.cap_y == pytest.approx(10.0)
    assert 10.0 < hoodoo.neck_z < 14.0
    assert hoodoo.neck_x == pytest.approx(4.0)
    assert hoodoo.neck_y == pytest.approx(6.0 if sides == "every" else 10.0)
    assert hoodoo.ratio_x == pytest.approx(0.4)
    assert hoodoo.retreat == pytest.approx(expected)


def test_a_wall_with_four_openings_between_pillars() -> None:
    """A wall 40 m long (cells of 0.5 m) with four openings 4 m wide and 5 m high at its foot,
    3 m apart (the second 1 m higher over its middle 3 m), a recess that does not go through
    and a hole of one pixel: four openings of 20 m² (23 m²), three pillars 3 m wide."""
    rock = np.zeros((90, 12, 60), dtype=bool)
    rock[5:85, 3:9, :52] = True
    for start in (17, 31, 45, 59):
        rock[start:start + 8, :, :10] = False
    rock[10:14, 3:6, 20:24] = False
    rock[70, :, 30] = False
    rock[32:38, :, 10:12] = False                     # the second opening 1 m higher over 3 m
    arcade = measure_arcade(rock, 0.5)
    assert arcade.openings == 4
    assert arcade.areas == pytest.approx((20.0, 23.0, 20.0, 20.0))
    assert arcade.spans == pytest.approx((4.0,) * 4)
    assert arcade.pillars == pytest.approx((3.0,) * 3)


def _block(h: float) -> np.ndarray:
    """A block whose face looking south starts at y cell 8, 30 m wide (cells 4–63), 26 m high."""
    rock = np.zeros((68, 40, 60), dtype=bool)
    rock[4:64, 8:36, :52] = True
    return rock


def test_a_box_recess_has_a_flat_roof() -> None:
    """A recess 20 m wide, 8 m high and 3 m deep (cells of 0.5 m): width 20 m, height 8 m, depth
    3 m, rise 0."""
    h = 0.5
    rock = _block(h)
    rock[14:54, 8:14, :16] = False
    alcove = measure_alcove(rock, h, face=8, columns=(4, 64), min_depth=1.0)
    assert alcove.width == pytest.approx(20.0)
    assert alcove.height == pytest.approx(8.0)
    assert alcove.depth == pytest.approx(3.0)
    assert alcove.area == pytest.approx(160.0)
    assert alcove.rise == pytest.approx(0.0, abs=1e-9)


def test_a_half_circle_recess_rises_by_its_analytic_rise() -> None:
    """A recess 3 m deep under a half-circle roof of radius 12 m springing from the ground: rise
    R(1 − √3/2) (as the windows average it) within a tenth of a cell plus 5 cm; width 2R within
    two cells."""
    h, radius = 0.5, 12.0
    rock = _block(h)
    x, z = np.meshgrid(_centres(68, h) - 17.0, _centres(60, h), indexing="ij")
    hollow = x**2 + z**2 < radius**2
    rock[:, 8:14, :] &= ~hollow[:, None, :]
    alcove = measure_alcove(rock, h, face=8, columns=(4, 64), min_depth=1.0)
    expected = _windowed_rise(lambda s: np.sqrt(np.maximum(0.0, radius**2 - (s - radius) ** 2)), 2 * radius)
    assert alcove.width == pytest.approx(2 * radius, abs=2 * h)
    assert alcove.depth == pytest.approx(3.0)
    assert alcove.rise == pytest.approx(expected, abs=0.1 * h + 0.05)
