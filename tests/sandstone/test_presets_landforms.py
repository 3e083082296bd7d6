"""The landforms of 002 Fig. 7 rows 1–4, each measured (``sandstone.landform_measures``) on the
final particles of the preset run as a user runs it: the command line with the preset's own
frames and dt, at 30 000 particles, voxelised on the lattice's surface grid (one particle per
filled cell; h the lattice spacing). Each asserts the landform's target and the value measured
when the preset was set (within a tolerance: a run is the same for a seed whatever the thread
count, but not bit for bit across CPUs and library versions).

Measured at 30 000 particles (h = 0.79 m for the arch, 0.46 m the hoodoo, 0.59 m the arcade,
0.72 m the alcove):
- arch (360 frames of 4000 y): one bridge joined to both supports over an opening 32.4 m wide,
  intrados 26.1 m above the ground at mid-span (the cap's base) and 19.3 m at the quarter-spans
  (rise 6.7 m, 8.5 h): the supports lean in towards a flat top under the cap;
- hoodoo (400 frames of 1000 y): a neck 2.8 m wide along x and along y under a cap 10.1 m wide
  (0.27 ×), narrowed by 3.7 m from each of its four sides;
- arcade (60 frames of 4000 y): three openings, pillars 5.3 m and 2.4 m wide between them;
- alcove (110 frames of 4000 y): a recess 27.2 m wide (all of the erodible face), 17.9 m high
  (to the hard top at 18 m), with a flat roof (rise 0): not the rounded alcove of Fig. 7 row 4.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from unerode_cli.io.particle_ply import read_particle_ply
from unerode_cli.sandstone import landform_measures as measures
from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.presets import preset_scene
from unerode_cli.sandstone.sampling import lattice_for

#: The particle count of these runs.
COUNT = 30_000


def _run(name: str, out: Path, *options: str) -> tuple[np.ndarray, Grid3D]:
    """The preset run by the command line at COUNT particles with its own frames and dt (and
    ``options``): the voxels of its final particles (rock and deposits) on the lattice's surface
    grid, and the grid."""
    result = subprocess.run(
        [sys.executable, "-m", "unerode_cli", "sandstone", name, str(out), "--particles", str(COUNT), "-q",
         *options],
        capture_output=True, text=True, timeout=1800, env={**os.environ, "NUMBA_NUM_THREADS": "2"})
    assert result.returncode == 0, result.stderr
    columns, origin = read_particle_ply(out / "particles.ply")
    positions = np.column_stack([columns[a] for a in ("x", "y", "z")]).astype(np.float64) + origin
    scene = preset_scene(name)
    lattice, _ = lattice_for(scene.shape, scene.low, np.asarray(scene.domain.size, dtype=float), COUNT)
    grid = lattice.surface_grid()
    return measures.voxelise(positions, grid), grid


@pytest.mark.slow
def test_the_arch_opens_under_a_bridge_with_a_rising_intrados(tmp_path: Path) -> None:
    """One opening seen across the fin, 32.4 m wide (the slit between the supports); the bridge
    over it is one piece of rock joined to both supports over the whole span; its intrados rises
    towards mid-span by ≥ 3 cells (2.4 m) — measured 6.7 m (26.1 m at mid-span, 19.3 m at the
    quarter-spans)."""
    rock, grid = _run("arch", tmp_path / "arch")
    arch = measures.measure_arch(rock, grid.h)
    assert arch.openings >= 1
    assert arch.span == pytest.approx(32.4, abs=2 * grid.h)
    assert arch.joined and arch.continuous
    assert arch.rise_cells >= 3.0
    assert arch.rise == pytest.approx(6.7, abs=2 * grid.h)
    assert arch.mid == pytest.approx(26.1, abs=2 * grid.h)


@pytest.mark.slow
def test_the_arch_needs_the_stress_and_its_interlocking_threshold(tmp_path: Path) -> None:
    """002 Fig. 13 and 16 on the arch preset (360 frames of 4000 y). Without the stress
    (``--no-stress``, I = ∞) the whole fin erodes alike into a flat slab on two legs: the
    opening's intrados rises by under one cell (measured 0.34 m, 0.4 h, against 6.7 m with the
    stress), and at most 40 % of the block's cells keep rock (28 %). With a low threshold,
    I = 0.25 MPa, the stressed rock interlocks at once and the erosion stops early (87 % of the
    particles interlocked): at least 80 % of the cells keep rock (90 %) and the opening stays
    within 3× the starting slit of 64 m² (156 m²)."""
    scene = preset_scene("arch")
    lattice, _ = lattice_for(scene.shape, scene.low, np.asarray(scene.domain.size, dtype=float), COUNT)
    block = 52.0 * 8.0 * 36.0 - 32.0 * 8.0 * 2.0          # the fin less its slit (m³)
    cells = block / lattice.surface_grid().h ** 3

    rock, grid = _run("arch", tmp_path / "no_stress", "--no-stress")
    arch = measures.measure_arch(rock, grid.h)
    assert arch.openings >= 1 and arch.rise_cells < 1.0
    assert rock.sum() < 0.4 * cells

    rock, grid = _run("arch", tmp_path / "low_threshold", "--I", "2.5e5")
    arch = measures.measure_arch(rock, grid.h)
    assert rock.sum() > 0.8 * cells
    assert 64.0 <= arch.area < 3 * 64.0


@pytest.mark.slow
def test_the_hoodoo_has_a_neck_narrowed_from_every_side(tmp_path: Path) -> None:
    """The neck under the cap (above 24 m) is at most 0.6 × the cap's width along x and along y
    — measured 2.8 m of 10.1 m (0.27 ×) both ways — and its four edges retreat inside the cap's
    by ≥ 1 m each (measured 3.7 m)."""
    rock, grid = _run("hoodoo", tmp_path / "hoodoo")
    hoodoo = measures.measure_hoodoo(rock, grid.h, cap_base=24.0)
    assert hoodoo.cap_x == pytest.approx(10.1, abs=grid.h)
    assert max(hoodoo.ratio_x, hoodoo.ratio_y) <= 0.6
    assert hoodoo.ratio_x == pytest.approx(0.27, abs=0.1)
    assert hoodoo.ratio_y == pytest.approx(0.27, abs=0.1)
    assert min(hoodoo.retreat) >= 1.0
    assert hoodoo.retreat == pytest.approx((3.7,) * 4, abs=1.5)


@pytest.mark.slow
def test_the_arcade_opens_between_pillars(tmp_path: Path) -> None:
    """≥ 3 openings through the wall (measured 3), each two separated by a pillar ≥ 1 m wide
    (measured 5.3 m and 2.4 m)."""
    rock, grid = _run("arcade", tmp_path / "arcade")
    arcade = measures.measure_arcade(rock, grid.h)
    assert arcade.openings >= 3
    assert arcade.openings == pytest.approx(3, abs=1)
    assert min(arcade.pillars) >= 1.0
    assert arcade.pillars[:2] == pytest.approx((5.3, 2.4), abs=1.5)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="the alcove's recess takes the whole erodible face up to the hard "
                   "top, with a flat roof: rise 0.0 m (width 27.2 m, height 17.9 m, 30 000 particles, "
                   "110 frames of 4000 y); a roof faces down, so a horizontal wind does not abrade it "
                   "(002 Eq. 8), and its compressive stress (0-0.3 MPa) is under the alcove's "
                   "interlocking thresholds (1.5-3 MPa, Table 1)")
def test_the_alcove_has_a_curved_roof(tmp_path: Path) -> None:
    """The recess in the front face (rock ≥ 1 m behind its initial plane, which began at y = 4 m)
    has a roof higher at mid-width than at the quarter-widths by ≥ 2 cells."""
    rock, grid = _run("alcove", tmp_path / "alcove")
    face = int(np.ceil(4.0 / grid.h - 0.5))
    columns = (int(np.floor(2.0 / grid.h)), int(np.ceil(32.0 / grid.h)))
    alcove = measures.measure_alcove(rock, grid.h, face, columns, min_depth=1.0)
    assert alcove.width == pytest.approx(27.2, abs=2 * grid.h)
    assert alcove.rise_cells >= 2.0
