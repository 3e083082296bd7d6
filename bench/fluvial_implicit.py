"""Implicit vs explicit forward fluvial erosion vs fastscapelib, single thread, CPU time.

    NUMBA_NUM_THREADS=1 .venv/bin/python bench/fluvial_implicit.py [--sizes 1024 2048] [--build [--accuracy]]

Per size, on a 30 m fractal DEM (``synthetic`` fractal noise, 800 m relief, its depressions
filled beforehand so that both libraries erode the same surface; K = 1e-5, m = 0.5, n = 1,
p = 1, all edges outlets), 1000 years of forward erosion, routing included:

- fastscapelib: priority flood + D8 routing + accumulation + one ``SPLEroder`` step;
- implicit D8 and MFD, K_d = 0 and K_d = 1 (one step, with the passes of the deposition
  iteration);
- explicit (000 Eq. 9) sub-stepped to its CFL bound as the runner does, D8 and MFD, K_d = 0.

CPU seconds (``time.process_time``, best of 3 after a warm-up), the ratio to fastscapelib, and
for the K_d = 0 D8 cases the correlation and eroded-volume ratio of the erosion maps against
fastscapelib's. ``--build`` also times the sample DEM's 2 My build (``sample_dems/README.md``)
with the explicit scheme at dt 2000 y and the implicit one at 2000, 8000, 20 000 and 100 000 y,
whole commands, and reports each result's RMS difference from the explicit build and the passes
of the deposition iteration per step. ``--accuracy`` adds the implicit builds at dt 500 y (the
time reference) and 1000 y and reports every build's time error against the reference: the RMS
and mean-elevation differences (m); and, as the floor below which an RMS difference says
nothing about the time step, the RMS difference between the implicit dt 2000 y build and the
same build from the base DEM perturbed by uniform noise of ±1 mm (the landscape's drainage
reorganises over 2 My, so that its elevations then depend on perturbations far below any time
error).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from unerode_cli.grid import Grid  # noqa: E402
from unerode_cli.hydro import outlet_mask, route  # noqa: E402
from unerode_cli.processes import fluvial, fluvial_implicit  # noqa: E402
from unerode_cli.run.runner import substeps_needed  # noqa: E402
from unerode_cli.synthetic import synthesize  # noqa: E402

DX = 30.0
DT = 1000.0
K, M, N = 1e-5, 0.5, 1.0


def cpu(work, repeats: int = 3) -> tuple[float, object]:
    """Best CPU time (s) of ``repeats`` runs after a warm-up, and the last result."""
    result = work()
    best = float("inf")
    for _ in range(repeats):
        start = time.process_time()
        result = work()
        best = min(best, time.process_time() - start)
    return best, result


def fastscapelib_step(z: np.ndarray):
    import fastscapelib as fs

    n = z.shape[0]
    grid = fs.RasterGrid([n, n], [DX, DX], fs.NodeStatus.FIXED_VALUE)
    graph = fs.FlowGraph(grid, [fs.PFloodSinkResolver(), fs.SingleFlowRouter()])
    eroder = fs.SPLEroder(graph, K, M, N, 1e-5)

    def work(keep_alive=grid):  # the flow graph does not own its grid
        filled = graph.update_routes(z)
        return eroder.erode(filled, graph.accumulate(1.0), DT)
    return work


def implicit_step(z: np.ndarray, grid: Grid, outlets: np.ndarray, method: str, k_d: float):
    params = fluvial.FluvialParams(k=K, k_d=k_d, m=M, n=N)

    def work():
        routing = route(z, grid, outlets, method)
        return fluvial_implicit.step(z, grid, outlets, params, DT, routing=routing)
    return work


def explicit_run(z: np.ndarray, grid: Grid, outlets: np.ndarray, method: str):
    params = fluvial.FluvialParams(k=K, k_d=0.0, m=M, n=N)

    def work():
        h = z.copy()
        left, steps = DT, 0
        while left > 0:
            routing = route(h, grid, outlets, method)
            stable = fluvial.max_stable_dt(h, grid, params, routing)
            dt = left / substeps_needed(left, stable)
            h += fluvial.step(h, grid, outlets, params, dt, routing=routing).dh
            left -= dt
            steps += 1
        return h - z, steps
    return work


def compare(size: int) -> None:
    raw = synthesize("fractal", (size, size), 800.0, seed=size).astype(np.float64)
    grid = Grid.full(raw.shape, DX)
    outlets = outlet_mask(grid, "all")
    # both libraries erode the same depression-free surface (each still routes it, timed):
    # fastscapelib's SPLEroder erodes the filled surface its sink resolver returns
    z = route(raw, grid, outlets, "d8").filled
    rows = []
    reference = None
    try:
        seconds, erosion = cpu(fastscapelib_step(z))
        reference = np.asarray(erosion)
        rows.append(("fastscapelib SPLEroder (pflood + D8 + 1 step)", seconds, "", ""))
    except ImportError:
        print("fastscapelib is not installed: no side-by-side figures")
    for method in ("d8", "mfd"):
        for k_d in (0.0, 1.0):
            seconds, done = cpu(implicit_step(z, grid, outlets, method, k_d))
            agreement = ""
            if reference is not None and method == "d8" and k_d == 0.0:
                ours = -done.change.dh
                r = np.corrcoef(ours.ravel(), reference.ravel())[0, 1]
                agreement = f"r = {r:.6f}, volume × {ours.sum() / reference.sum():.5f}"
            rows.append((f"implicit {method} K_d = {k_d:g} (1 step)", seconds,
                         f"{done.passes} passes, residual {done.residual:.2g}", agreement))
    for method in ("d8", "mfd"):
        seconds, (_, steps) = cpu(explicit_run(z, grid, outlets, method), repeats=1)
        rows.append((f"explicit {method} K_d = 0", seconds, f"{steps} sub-steps", ""))
    base = rows[0][1] if reference is not None else None
    print(f"\n### {size}² at {DX:g} m, {DT:g} y, single thread, CPU s\n")
    print("| case | CPU s | × fastscapelib | solver | agreement with fastscapelib |")
    print("|---|---|---|---|---|")
    for name, seconds, solver, agreement in rows:
        ratio = f"{seconds / base:.2f}" if base else "–"
        print(f"| {name} | {seconds:.3f} | {ratio} | {solver} | {agreement} |")


BUILD_RUNS = (("explicit", 2000), ("implicit", 2000), ("implicit", 8000), ("implicit", 20000),
              ("implicit", 100000))
#: the time reference and the convergence check of ``--accuracy``
ACCURACY_RUNS = (("implicit", 500), ("implicit", 1000))
#: half-width (m) of the uniform noise added to the base DEM for the noise floor
PERTURBATION = 1e-3
BUILD_OPTIONS = ("--process", "fluvial,hillslope", "--uplift", "5e-4", "--K", "5e-5", "--K-d", "1",
                 "--k-h", "0.01", "--duration", "2000000", "--sea-level", "0", "--outlets", "S")


def erode_build(cli: str, base: Path, out: Path, scheme: str,
                dt: int) -> tuple[float, float, np.ndarray, float]:
    """One 2 My build, whole command: (wall s, CPU s, elevation at 2 My (m), passes of the
    deposition iteration per step)."""
    import json

    import rasterio

    start, before = time.perf_counter(), os.times()
    subprocess.run([cli, "erode", str(base), str(out), "--scheme", scheme, "--dt", str(dt), *BUILD_OPTIONS],
                   check=True, capture_output=True)
    after = os.times()
    wall = time.perf_counter() - start
    used = after.children_user - before.children_user + after.children_system - before.children_system
    with rasterio.open(out) as ds:
        h = ds.read(1).astype(np.float64)
    stats = json.loads(Path(f"{out}.json").read_text())["statistics"]
    return wall, used, h, stats.get("fluvial_implicit_passes", 0) / max(stats["steps"], 1)


def perturbed(base: Path, out: Path) -> Path:
    """``base`` plus uniform noise of ±:data:`PERTURBATION` m (seed 1), written to ``out``."""
    import rasterio

    with rasterio.open(base) as ds:
        profile, z = ds.profile, ds.read(1)
    noise = np.random.default_rng(1).uniform(-PERTURBATION, PERTURBATION, z.shape)
    with rasterio.open(out, "w", **profile) as ds:
        ds.write((z + noise).astype(z.dtype), 1)
    return out


def rms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)))


def build(accuracy: bool = False) -> None:
    """The sample DEM's 2 My build, whole commands; with ``accuracy`` the time errors too."""
    cli = str(ROOT / ".venv" / "bin" / "unerode-cli")
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "base.tif"
        subprocess.run([cli, "synth", str(base), "--kind", "mountain", "--size", "256", "--dx", "30",
                        "--seed", "7", "--relief", "300", "--crs", "EPSG:32632", "--centre",
                        "650000,5200000"], check=True, capture_output=True)
        runs = (ACCURACY_RUNS if accuracy else ()) + BUILD_RUNS
        done = {run: erode_build(cli, base, Path(tmp) / f"{run[0]}_{run[1]}.tif", *run) for run in runs}
        explicit = done["explicit", 2000][2]
        reference = done["implicit", 500][2] if accuracy else None
        print("\n### sample DEM 2 My build (256² at 30 m, fluvial + hillslope), whole command\n")
        print("| scheme | dt (y) | wall s | CPU s | passes per step | RMS difference from explicit (m) "
              "| mean elevation (m) | RMS from implicit dt 500 (m) | mean − reference (m) |")
        print("|---|---|---|---|---|---|---|---|---|")
        for scheme, dt in runs:
            wall, used, h, passes = done[scheme, dt]
            errors = "– | –"
            if reference is not None:
                errors = f"{rms(h, reference):.1f} | {h.mean() - reference.mean():+.2f}"
            print(f"| {scheme} | {dt} | {wall:.1f} | {used:.1f} | {passes:.2f} | {rms(h, explicit):.1f} "
                  f"| {h.mean():.2f} | {errors} |")
        if accuracy:
            noisy = erode_build(cli, perturbed(base, Path(tmp) / "noisy.tif"), Path(tmp) / "noisy_out.tif",
                                "implicit", 2000)[2]
            same = done["implicit", 2000][2]
            print(f"\nnoise floor: implicit dt 2000 from the base ± {PERTURBATION * 1e3:g} mm: RMS "
                  f"{rms(noisy, same):.1f} m from the unperturbed build, "
                  f"mean {noisy.mean() - same.mean():+.2f} m")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[1024, 2048],
                        help="DEM sizes of the one-step comparison (none: only --build)")
    parser.add_argument("--build", action="store_true", help="also time the sample DEM's 2 My build")
    parser.add_argument("--accuracy", action="store_true",
                        help="with --build: also the time errors against the implicit dt 500 y build")
    args = parser.parse_args()
    for size in args.sizes:
        compare(size)
    if args.build:
        build(args.accuracy)


if __name__ == "__main__":
    main()
