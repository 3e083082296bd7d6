"""Nested runs across scales (000 §6.3.1), measured against a 30 m reference.

Big Tujunga (SRTM 30 m, ../shared/data): a 12 × 10 km box unerodes back 6 ka (fluvial, K 2e-5)
at 90 m (the coarse run, with --write-fluxes) and at 30 m (the reference); a 2.7 × 2.7 km window
of the main stem (90 × 90 cells of 30 m, rows 50–79 and columns 20–49 of the 90 m grid) runs
at 30 m with inflow from the coarse run (nested) and without (alone): with every edge an outlet,
with outlets on the edges the main stem leaves by (S, W), and nested with the outlets a nested
run takes when given none (where the coarse run's water leaves the window,
``run.nesting.crossing_outlets``), compared with the lone window with outlets S, W (the edges
that water leaves by, the fair lone run). The RMSE (m) of each window against the reference's
window (its 3-cell boundary ring left out) and the ratios alone / nested are printed as JSON.

    .venv/bin/python bench/nested_scales.py [WORK_FOLDER]
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
TUJUNGA = DATA / "dem" / "sangabriel_bigtujunga" / "bigtujunga.tif"
BOX = "388000,3792000,400000,3802000"
WINDOW = (50, 80, 20, 50)          # rows, columns of the 90 m grid
RUN = ("--chronology", DATA / "lr04" / "LR04stack.txt", "--from", 0, "--to", 6, "--dt", 1000,
       "--process", "fluvial", "--K", 2e-5, "--overwrite", "-q")


def cli(*args: object) -> None:
    subprocess.run([sys.executable, "-m", "unerode_cli", *map(str, args)], check=True)


def main(work: Path) -> dict[str, float]:
    from unerode_cli.io.rasters import read_terrain

    cli("convert", TUJUNGA, work / "coarse90.tif", "--crop", BOX, "--cell-size", 90, "--overwrite")
    cli("convert", TUJUNGA, work / "ref30.tif", "--crop", BOX, "--overwrite")
    coarse = read_terrain(work / "coarse90.tif")
    r0, r1, c0, c1 = WINDOW
    x0, y0 = coarse.transform @ (c0, r1)
    x1, y1 = coarse.transform @ (c1, r0)
    cli("convert", TUJUNGA, work / "window30.tif", "--crop", f"{x0},{y0},{x1},{y1}", "--overwrite")
    cli("climate-run", work / "coarse90.tif", work / "coarse_past.tif", *RUN, "--write-fluxes")
    cli("climate-run", work / "ref30.tif", work / "ref_past.tif", *RUN)
    runs = {"nested_all": ("--inflow-from", work / "coarse_past.tif", "--outlets", "all"),
            "alone_all": ("--outlets", "all"),
            "nested_sw": ("--inflow-from", work / "coarse_past.tif", "--outlets", "S,W"),
            "alone_sw": ("--outlets", "S,W"),
            "nested_auto": ("--inflow-from", work / "coarse_past.tif")}
    for name, extra in runs.items():
        cli("climate-run", work / "window30.tif", work / f"{name}.tif", *RUN, *extra)
    reference = read_terrain(work / "ref_past.tif")
    window = read_terrain(work / "window30.tif")
    col, row = (int(v) for v in ~reference.transform @ (window.transform.c + 15.0, window.transform.f - 15.0))
    ny, nx = window.shape
    expected = reference.elevation[row:row + ny, col:col + nx]
    inner = (slice(3, -3), slice(3, -3))
    errors = {name: (read_terrain(work / f"{name}.tif").elevation - expected)[inner] for name in runs}
    rmse = {name: float(np.sqrt(np.mean(error**2))) for name, error in errors.items()}
    change = float(np.sqrt(np.mean((expected - window.elevation)[inner] ** 2)))
    return {**{f"rmse_{k}_m": round(v, 3) for k, v in rmse.items()},
            "reference_change_rms_m": round(change, 3),
            "ratio_all_edges": round(rmse["alone_all"] / rmse["nested_all"], 2),
            "ratio_outlets_sw": round(rmse["alone_sw"] / rmse["nested_sw"], 2),
            "ratio_outlets_sw_vs_alone_all_edges": round(rmse["alone_all"] / rmse["nested_sw"], 2),
            "ratio_auto_outlets_vs_alone_sw": round(rmse["alone_sw"] / rmse["nested_auto"], 2),
            "ratio_auto_outlets_vs_alone_all_edges": round(rmse["alone_all"] / rmse["nested_auto"], 2)}


if __name__ == "__main__":
    if len(sys.argv) > 1:
        folder = Path(sys.argv[1])
        folder.mkdir(parents=True, exist_ok=True)
        print(json.dumps(main(folder), indent=1))
    else:
        with tempfile.TemporaryDirectory() as tmp:
            print(json.dumps(main(Path(tmp)), indent=1))
