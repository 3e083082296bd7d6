"""Ice geometry and map-edge figures of a `glaciate` run (against measured valley glaciers).

Runs ``unerode-cli glaciate DEM ... --ice --velocity --sliding`` (the options after ``--`` are
passed on) and prints, as JSON:

- ice volume (km³), the share of the valid cells with any ice, with ≥ 1 cm and with ≥ 1 m, the
  number of cells with a film (0 < H < 1 cm) and the thinnest ice kept (m);
- the median surface slope (°) of the ice thicker than 20 m, and the median and 90th percentile
  of the driving stress ρ g H tan α (kPa, ρ = 910 kg/m³) of the ice thicker than 50 m
  (valley glaciers: slopes of 2–10°, 50–150 kPa; Cuffey & Paterson 2010, ch. 8);
- the edge band (cells within ``--edge-band`` m of the map's edge): its share of the area, its
  share of the eroded rock (the ratio of the two) and its share of the fastest 1 % of the ice
  (by surface speed, among cells with ≥ 1 m of ice) against its share of the ice area.

Usage::

    python bench/glacier_geometry.py DEM OUTDIR [--edge-band 500] -- --ela 2900 --duration 2000 ...
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import rasterio

RHO_G = 910.0 * 9.81


def _read(path: Path, band: int = 1) -> np.ndarray:
    with rasterio.open(path) as src:
        return src.read(band).astype(np.float64)


def _cell_size(path: Path) -> tuple[float, float]:
    from unerode_cli.io.rasters import read_terrain

    terrain = read_terrain(path)
    return float(terrain.grid.dx), float(np.mean(terrain.grid.dy))


def figures(dem: Path, out: Path, edge_band: float) -> dict:
    bed0 = _read(dem)
    bed = _read(out / "bed.tif")
    ice = _read(out / "ice.tif")
    vx, vy = _read(out / "v.tif", 1), _read(out / "v.tif", 2)
    dx, dy = _cell_size(dem)
    valid = np.isfinite(bed) & np.isfinite(bed0) & np.isfinite(ice)
    ice = np.where(valid, ice, 0.0)
    surface = np.where(valid, bed + ice, np.nan)
    gy, gx = np.gradient(surface, dy, dx)
    slope = np.arctan(np.hypot(gx, gy))
    speed = np.hypot(vx, vy)
    eroded = np.where(valid, np.maximum(bed0 - bed, 0.0), 0.0)
    ny, nx = bed.shape
    jj, ii = np.mgrid[0:ny, 0:nx]
    dist = np.minimum.reduce([jj * dy, (ny - 1 - jj) * dy, ii * dx, (nx - 1 - ii) * dx])
    band = valid & (dist < edge_band)
    thick20, thick50, ice1 = valid & (ice > 20), valid & (ice > 50), valid & (ice >= 1.0)
    tau = RHO_G * ice * np.tan(slope) / 1e3
    fast = np.zeros_like(valid)
    if ice1.any():
        cut = np.percentile(speed[ice1], 99)
        fast = ice1 & (speed >= cut)
    n_valid = valid.sum()
    films = valid & (ice > 0) & (ice < 0.01)
    positive = ice[valid & (ice > 0)]
    return {
        "ice_volume_km3": float(ice[valid].sum() * dx * dy / 1e9),
        "ice_any_share": float((valid & (ice > 0)).sum() / n_valid),
        "ice_1cm_share": float((valid & (ice >= 0.01)).sum() / n_valid),
        "ice_1m_share": float(ice1.sum() / n_valid),
        "film_cells": int(films.sum()),
        "film_volume_m3": float(ice[films].sum() * dx * dy),
        "thinnest_ice_m": float(positive.min()) if positive.size else 0.0,
        "max_ice_m": float(ice.max()),
        "median_slope_deg_H20": float(np.degrees(np.median(slope[thick20]))) if thick20.any() else None,
        "median_tau_kPa_H50": float(np.median(tau[thick50])) if thick50.any() else None,
        "p90_tau_kPa_H50": float(np.percentile(tau[thick50], 90)) if thick50.any() else None,
        "eroded_m3": float(eroded.sum() * dx * dy),
        "edge_area_share": float(band.sum() / n_valid),
        "edge_erosion_share": float(eroded[band].sum() / max(eroded.sum(), 1e-300)),
        "edge_erosion_ratio": float(eroded[band].sum() / max(eroded.sum(), 1e-300) / (band.sum() / n_valid)),
        "edge_ice_share": float((band & ice1).sum() / max(ice1.sum(), 1)),
        "edge_fastest1pc_share": float((band & fast).sum() / max(fast.sum(), 1)),
        "fastest_speed_m_y": float(speed[ice1].max()) if ice1.any() else 0.0,
        "fastest_cell_edge_distance_cells": (float(dist[ice1][np.argmax(speed[ice1])] / dx)
                                             if ice1.any() else None),
    }


def main() -> None:
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[:argv.index("--")] if "--" in argv else argv
    parser = argparse.ArgumentParser()
    parser.add_argument("dem", type=Path)
    parser.add_argument("outdir", type=Path)
    parser.add_argument("--edge-band", type=float, default=500.0)
    parser.add_argument("--skip-run", action="store_true")
    args = parser.parse_args(argv)
    out = args.outdir
    out.mkdir(parents=True, exist_ok=True)
    seconds = None
    if not args.skip_run:
        command = [sys.executable, "-m", "unerode_cli", "glaciate", str(args.dem), str(out / "bed.tif"),
                   "--ice", str(out / "ice.tif"), "--velocity", str(out / "v.tif"),
                   "--timeline", str(out / "timeline.csv"), "--overwrite", *extra]
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True)
        seconds = time.perf_counter() - start
        (out / "stdout.txt").write_text(done.stdout + done.stderr)
        if done.returncode:
            print(done.stdout, done.stderr, file=sys.stderr)
            sys.exit(done.returncode)
    result = {"seconds": seconds, "command_options": extra, **figures(args.dem, out, args.edge_band)}
    (out / "figures.json").write_text(json.dumps(result, indent=1))
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
