"""001 §7.1 / Fig. 8 as an experiment: does a glacier leave a tributary valley hanging?

A trunk V valley draining east along the map's south part (48 × 128 cells of 50 m; 30° walls,
400 m deep, floor graded at 0.1, headwall at the west) and a tributary V valley (30° walls, 1.6 km
long) joining it from the north at x = 3 km, its floor graded at 0.25 down to the trunk's floor
at the junction: the valleys meet at an accordant level, as rivers do (Playfair's law). The
glaciers are spun up without erosion under an ELA of 2100 m, then erode their beds by abrasion
and quarrying alone (Blatter–Pattyn, 001 Table 1's top rates × F = 20, 20-year steps) while the
climate cools and the ELA falls linearly to 1763 m, the forcing of ``glacier_u_valley.py``.

Measures: ``hanging_height``, the height at which the tributary's floor, carried down at its
own gradient from its mouth (the top of the trunk's initial walls), meets the trunk's axis above
the trunk's floor — 0 for graded valleys; and ``analysis.landforms.hanging_steps`` (what
``unerode-cli landforms`` reports: the drop of the tributary's last 250 m before the junction
minus the trunk's gradient times that length, the trunk being its axis, row ``trunk_row``),
which on this geometry measures within the trunk's own trough and counts a tributary steeper
than the trunk as a step even before any erosion.

Usage::

    NUMBA_NUM_THREADS=1 python bench/glacier_hanging_valley.py [--out docs] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from unerode_cli.analysis.landforms import Settings, hanging_steps
from unerode_cli.analysis.river import RiverPath
from unerode_cli.glacier import coupled
from unerode_cli.grid import Grid
from unerode_cli.hydro.outlets import outlet_mask

sys.path.insert(0, str(Path(__file__).resolve().parent))

import glacier_u_valley as uv  # noqa: E402

WALL = math.tan(math.radians(uv.WALL_DEG))


@dataclass(frozen=True)
class Confluence:
    """The two valleys (metres)."""

    ny: int = 48
    nx: int = 128
    dx: float = 50.0
    trunk_row: int = 32           # the trunk's axis (row); the tributary lies north of it
    junction_x: float = 3000.0    # where the tributary's axis meets the trunk's (m from the west)
    floor_head: float = 2000.0    # trunk floor at the west edge without the headwall (m)
    gradient: float = 0.1         # trunk floor gradient (m/m)
    relief: float = 400.0         # depth of both Vs (m); beyond, 10° shoulders
    headwall: float = 300.0
    headwall_m: float = 600.0
    tributary_gradient: float = 0.25

    def bed(self) -> np.ndarray:
        """float64[ny, nx] bed elevation (m): the lower of the two V valleys."""
        y, x = np.mgrid[0:self.ny, 0:self.nx] * self.dx
        shoulder = math.tan(math.radians(uv.SHOULDER_DEG))
        half = self.relief / WALL

        def across(d: np.ndarray) -> np.ndarray:
            return np.where(d < half, WALL * d, self.relief + shoulder * (d - half))

        trunk_floor = self.floor_head - self.gradient * x
        trunk_floor += self.headwall * np.clip(1.0 - x / self.headwall_m, 0.0, None) ** 2
        y_axis = self.trunk_row * self.dx
        trunk = trunk_floor + across(np.abs(y - y_axis))
        junction_floor = self.floor_head - self.gradient * self.junction_x
        tributary_floor = junction_floor + self.tributary_gradient * np.clip(y_axis - y, 0.0, None)
        tributary = np.where(y <= y_axis, tributary_floor + across(np.abs(x - self.junction_x)), np.inf)
        return np.minimum(trunk, tributary)

    def trunk_path(self) -> RiverPath:
        """The trunk's axis from the east edge (downstream end first) to its head (column 0)."""
        cols = np.arange(self.nx - 1, -1, -1, dtype=np.float64)
        rows = np.full(self.nx, float(self.trunk_row))
        return RiverPath(rows, cols, (self.nx - 1 - cols) * self.dx, "the trunk's axis")


def steps(bed: np.ndarray, grid: Grid, confluence: Confluence) -> list[dict]:
    """Every tributary junction on the trunk (``hanging_steps``): its column, step (m), drop (m)."""
    outlets = outlet_mask(grid, "E")
    found = hanging_steps(bed, grid, outlets, confluence.trunk_path(), Settings())
    return [{"col": int(j.col), "row": int(j.row), "step_m": float(j.step_m), "drop_m": float(j.drop_m),
             "area_km2": float(j.area_m2) / 1e6} for j in found.junctions]


def hanging_height(bed: np.ndarray, confluence: Confluence, reach_m: float = 500.0) -> float:
    """Height (m) at which the tributary's floor, carried down to the trunk's axis at its own
    gradient, meets the trunk's floor: the tributary's axis (column of ``junction_x``) is fitted
    by least squares between its mouth — the top of the trunk's initial walls, ``relief``/tan 30°
    from the trunk's axis — and ``reach_m`` further up, and the line is extended to the axis.
    0 for valleys graded to each other (as before any erosion); the height of the lip above
    the trunk's floor when the tributary hangs (001 §7.1)."""
    col = int(round(confluence.junction_x / confluence.dx))
    up = (confluence.trunk_row - np.arange(confluence.trunk_row + 1)) * confluence.dx
    floor = bed[: confluence.trunk_row + 1, col]
    mouth = confluence.relief / WALL
    upper = (up >= mouth - 1e-9) & (up <= mouth + reach_m + 1e-9)
    slope, intercept = np.polyfit(up[upper], floor[upper], 1)
    return float(intercept - bed[confluence.trunk_row, col])


def experiment(confluence: Confluence, setup: uv.Setup) -> dict:
    """Spin up, erode, measure the tributary's step before and after."""
    bed0 = confluence.bed()
    grid = Grid.full(bed0.shape, confluence.dx)
    started = time.perf_counter()
    params_still = uv._params(setup, grid, False)
    spun = coupled.run(coupled.GlacierState(bed0, np.zeros_like(bed0)), grid, params_still,
                       setup.valley.ela, coupled.step_times(setup.spinup_years, setup.dt)).state
    ela = coupled.ElaTable(np.array([setup.spinup_years, setup.spinup_years + setup.years]),
                           np.array([setup.valley.ela, setup.ela_end]))
    times = setup.spinup_years + coupled.step_times(setup.years, setup.dt)
    result = coupled.run(spun, grid, uv._params(setup, grid, True), ela, times)
    final = result.state
    col = int(round(confluence.junction_x / confluence.dx))
    return {"seconds": time.perf_counter() - started, "unconverged_solves": result.unconverged,
            "spinup_volume_km3": coupled.ice_volume(spun.thickness, grid) / 1e9,
            "final_volume_km3": coupled.ice_volume(final.thickness, grid) / 1e9,
            "trunk_ice_m": float(spun.thickness[confluence.trunk_row, col]),
            "tributary_ice_m": float(spun.thickness[confluence.trunk_row // 2, col]),
            "trunk_lowered_m": float(bed0[confluence.trunk_row, col] - final.bed[confluence.trunk_row, col]),
            "tributary_lowered_m": float(bed0[confluence.trunk_row - 12, col]
                                         - final.bed[confluence.trunk_row - 12, col]),
            "before": steps(bed0, grid, confluence), "after": steps(final.bed, grid, confluence),
            "hanging_before_m": hanging_height(bed0, confluence),
            "hanging_after_m": hanging_height(final.bed, confluence),
            "fields": {"bed0": bed0, "final": final}}


def plot(outcome: dict, confluence: Confluence, out_dir: Path) -> Path:
    """The tributary's long profile (its axis) and the trunk's floor, before and after."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bed0, final = outcome["fields"]["bed0"], outcome["fields"]["final"]
    col = int(round(confluence.junction_x / confluence.dx))
    y = (confluence.trunk_row - np.arange(confluence.trunk_row + 1)) * confluence.dx
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    ax = axes[0]
    ax.plot(y, bed0[: confluence.trunk_row + 1, col], "k--", label="bed before")
    ax.plot(y, final.bed[: confluence.trunk_row + 1, col], "r-", label="bed after")
    ax.plot(y, (final.bed + final.thickness)[: confluence.trunk_row + 1, col], "b-", lw=0.8,
            label="ice surface at the end")
    ax.set_xlabel("distance up the tributary from the trunk's axis (m)")
    ax.set_ylabel("elevation (m)")
    ax.set_title("tributary axis")
    ax.legend()
    ax = axes[1]
    x = np.arange(confluence.nx) * confluence.dx / 1000
    ax.plot(x, bed0[confluence.trunk_row], "k--", label="trunk floor before")
    ax.plot(x, final.bed[confluence.trunk_row], "r-", label="trunk floor after")
    ax.axvline(confluence.junction_x / 1000, color="0.5", lw=0.8, ls=":")
    ax.set_xlabel("down the trunk (km)")
    ax.set_title("trunk axis (dotted: the junction)")
    ax.legend()
    before, after = outcome["hanging_before_m"], outcome["hanging_after_m"]
    fig.suptitle(f"the tributary's floor projected to the trunk's axis lies {before:.0f} m above the "
                 f"trunk's floor before, {after:.0f} m after")
    fig.tight_layout()
    path = out_dir / "hanging_valley.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--years", type=float, default=uv.Setup.years)
    ap.add_argument("--rows", type=int, default=Confluence.ny, help="map rows (the tributary's length)")
    ap.add_argument("--trunk-row", type=int, default=Confluence.trunk_row)
    ap.add_argument("--tributary-gradient", type=float, default=Confluence.tributary_gradient)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    confluence = Confluence(ny=args.rows, trunk_row=args.trunk_row,
                            tributary_gradient=args.tributary_gradient)
    outcome = experiment(confluence, uv.Setup(years=args.years))
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        print("wrote", plot(outcome, confluence, args.out))
    report = {k: v for k, v in outcome.items() if k != "fields"}
    print(json.dumps(report, indent=1))
    if args.json is not None:
        args.json.write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
