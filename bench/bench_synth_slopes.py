"""Slopes of `synth`'s terrains at a fixed 2000 m of relief and at the default relief (2000 m or
less, so that the land's median slope is at most 30°), against the real DEMs of ../shared/data.

    .venv/bin/python bench/bench_synth_slopes.py

For each kind, size (30 m cells) and seed: the median slope of the land (cells above 0 m,
central differences) and the share of cells steeper than 70° (run/terrain_sanity.py's
criterion refuses more than 25 %), at 2000 m and at the default relief.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from unerode_cli.io.rasters import read_terrain
from unerode_cli.run.terrain_sanity import cliff_share
from unerode_cli.synthetic import relief_for_extent, shape_of

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "dem"
REAL = ["alps_grindelwald/dem.tif", "alps_oetztal/srtm_oetztal.tif",
        "patagonia_exploradores/AST_L1A_00303182012144228_Z.tif", "sangabriel_bigtujunga/bigtujunga.tif",
        "himalaya_mandakini/Mandakini.bil"]


def median_slope(z: np.ndarray, dx: float, dy: float, land_only: bool) -> float:
    gy, gx = np.gradient(z, dy, dx)
    slope = np.degrees(np.arctan(np.hypot(gx, gy)))
    keep = np.isfinite(slope) & ((z > 0.0) if land_only else True)
    return float(np.median(slope[keep]))


def main() -> None:
    print("real DEMs: median slope, cells steeper than 70°")
    for name in REAL:
        path = SHARED / name
        if path.exists():
            t = read_terrain(path)
            print(f"  {name.split('/')[0]:24s} {median_slope(t.elevation, t.dx, t.dy, False):5.1f}°  "
                  f"{100 * cliff_share(t.elevation, t.dx, t.dy):5.2f} %")
    dx = 30.0
    print("synth (30 m cells): kind size seed | 2000 m: land median, > 70° "
          "| default: relief, land median, > 70°")
    for kind in ("mountain", "fractal"):
        for size in (16, 32, 64, 128, 256, 512, 1024):
            for seed in (1, 7):
                relative = shape_of(kind, (size, size), seed)
                fixed = 2000.0 * relative
                relief = relief_for_extent(relative, dx, dx)
                made = relief * relative
                print(f"  {kind:8s} {size:5d} {seed:2d} | {median_slope(fixed, dx, dx, True):5.1f}° "
                      f"{100 * cliff_share(fixed, dx, dx):5.1f} % | {relief:6.0f} m "
                      f"{median_slope(made, dx, dx, True):5.1f}° {100 * cliff_share(made, dx, dx):5.2f} %")


if __name__ == "__main__":
    main()
