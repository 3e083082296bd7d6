"""001 §7.1 / Fig. 13 as an experiment: does a glacier turn a V valley into a U?

A synthetic V valley draining east (x, columns) with 30° walls, graded floor and a headwall;
beyond the walls, 10° shoulders up to the map's north and south edges. The glacier is spun up
without erosion under a constant ELA (2100 m), then erodes its bed by abrasion and quarrying
alone (no hill slope, debris flow or rivers: ``coupled.run`` with ``after=None``), Blatter–Pattyn,
SIA or the CNN of 001 §4–5 (``--iceflow cnn``, ``glacier.cnn_iceflow``: one network, seeded by
``--seed``, trained on the fly through the spin-up and the erosion; its steps that miss the
converged solver's residual 1e-3 are finished by that solver, and the run counts them), while
the climate cools: the ELA falls linearly to ``ela_end`` (1763 m) by the end of the run, 337 m
in all, about the depth the glacier cuts. Under a constant ELA the glacier sinks with
its bed into warmer air and thins (``--constant-ela``): the trough's exponent then peaks at 1.53
after 22.5 ky-equivalent and falls back as the ice thins to 45 m. With ``--iceflow cnn`` (seed 0)
b rises 1.00 → 1.578 (trough 1.518) as with the converged solver, the same to three decimals at
every 250 y (5 ky-equivalent), the converged solver finishing all 167 of the network's solves
(50 spin-up, 117 eroding); 547 s against its 286 s (one thread on 2 busy cores,
``--snapshot-every 250``).

Erosion (001 §6.1, Table 1): l = 2.02, k_e = 1.1e-6 m^(1−l)·y^(l−1) and k_q = 2.6e-4, the top of
Table 1's ranges (its most erodible rock), both multiplied by a stated morphological factor F
(as 001 Fig. 17 multiplies its erosion by 4): T simulated years erode like F·T years. Default:
F = 20 over 2250 years (45 ky-equivalent) in 20-year steps.

Measure: the exponent b of z = z0 + a·|y − y0|^b (``analysis.landforms.fit_power_law``, the fit
of the ``landforms`` command) on every column (the sections are straight across the valley)
between the walls' tops (|y − y_c| ≤ the walls' half-width, the same window before and after),
over the glacier's middle reach: the columns between 25 % and 75 % of the way from the head to
the snout of the spun-up glacier (the last column whose centre holds ≥ 10 m of ice). b ≈ 1 for
a V, 2 for a parabolic U. The trough's b is fitted the same way within the spun-up trunk
glacier's margins (``trough_half_widths``). ``--diagnose`` prints, at the end of the spin-up and
of the run, the ice thickness, sliding speed, quarrying focus Q and erosion rates across a
middle section, and their means over the floor, the lower walls under the trough's margins and
the wall films.

Usage::

    NUMBA_NUM_THREADS=1 python bench/glacier_u_valley.py [--iceflow sia|cnn] [--seed 0] [--factor 20]
        [--years 2250] [--constant-ela] [--out docs] [--json out.json] [--diagnose]

Writes ``u_valley_sections.png`` (before/after sections) and ``u_valley_map.png`` (bed lowering,
ice outline, middle reach) into ``--out`` when given (with ``--tag`` in their names).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from unerode_cli.analysis.landforms import fit_power_law
from unerode_cli.glacier import blatter, coupled, erosion
from unerode_cli.grid import Grid
from unerode_cli.hydro.outlets import outlet_mask

#: 001 Table 1, the top of its ranges (most erodible rock).
TABLE1_K_E = 1.1e-6
TABLE1_K_Q = 2.6e-4
WALL_DEG = 30.0
SHOULDER_DEG = 10.0
SNOUT_ICE_M = 10.0
#: The ELA (m) that the eroding run's climate cools to (module docstring).
COOLED_ELA = 1763.0


@dataclass(frozen=True)
class Valley:
    """The synthetic V valley and its climate (metres, years)."""

    ny: int = 40
    nx: int = 128
    dx: float = 50.0
    floor_head: float = 2000.0   # floor elevation at the west edge without the headwall (m)
    gradient: float = 0.1        # down-valley floor gradient (m/m)
    relief: float = 565.0        # height of the 30° walls above the floor (m): 565 reaches the edges
    headwall: float = 300.0      # extra height of the head, fading over ``headwall_m`` (m)
    headwall_m: float = 600.0
    ela: float = 2100.0

    @property
    def wall_half_width(self) -> float:
        """Half-width of the V at the walls' tops (m)."""
        return self.relief / math.tan(math.radians(WALL_DEG))

    def bed(self) -> np.ndarray:
        """float64[ny, nx] bed elevation (m)."""
        y, x = np.mgrid[0:self.ny, 0:self.nx] * self.dx
        d = np.abs(y - (self.ny - 1) * self.dx / 2)
        w = self.wall_half_width
        across = np.where(d < w, math.tan(math.radians(WALL_DEG)) * d,
                          self.relief + math.tan(math.radians(SHOULDER_DEG)) * (d - w))
        floor = self.floor_head - self.gradient * x
        floor += self.headwall * np.clip(1.0 - x / self.headwall_m, 0.0, None) ** 2
        return floor + across


@dataclass(frozen=True)
class Setup:
    """How the experiment runs."""

    valley: Valley = field(default_factory=Valley)
    iceflow: str = "blatter"
    factor: float = 20.0          # morphological acceleration F of k_e and k_q
    k_e: float = TABLE1_K_E
    k_q: float = TABLE1_K_Q
    spinup_years: float = 1000.0
    years: float = 2250.0         # simulated years of erosion (× factor = eroding years)
    dt: float = 20.0
    snapshot_every: float = 100.0
    snow_slopes: tuple[float, float] | None = None  # None: the model's default
    sliding_c: float | None = None                  # None: the model's default C
    ela_end: float | None = COOLED_ELA  # ELA (m) reached linearly at the end of the erosion (None: constant)
    frozen_above: float | None = None  # what-if: C = ∞ (frozen) on walls this high above the floor (m)
    seed: int = 0                      # the CNN's weights (iceflow "cnn")


def _params(setup: Setup, grid: Grid, eroding: bool, cnn: object = None) -> coupled.CoupledParams:
    """The run's parameters; ``cnn`` the network that ``iceflow="cnn"`` carries (one for the whole
    experiment, so that it keeps learning from the spin-up into the erosion)."""
    fields = {f.name for f in dataclasses.fields(coupled.CoupledParams)}
    extra = {}
    edges = outlet_mask(grid, "all")
    for name in ("edge_cells", "held_bed"):  # what the glaciate command passes for open edges
        if name in fields:
            extra[name] = edges
            break
    if setup.snow_slopes is not None:
        extra["snow_slope_min"], extra["snow_slope_max"] = setup.snow_slopes
    c = blatter.DEFAULT_SLIDING_C if setup.sliding_c is None else setup.sliding_c
    if setup.frozen_above is not None:
        bed0 = setup.valley.bed()
        c = np.where(bed0 - bed0.min(axis=0) > setup.frozen_above, math.inf, c)
    if setup.sliding_c is not None or setup.frozen_above is not None:
        extra["flow"] = blatter.FlowParams(sliding_c=c)
    if cnn is not None:
        extra["cnn"] = cnn
    return coupled.CoupledParams(iceflow=setup.iceflow, erosion=eroding, k_e=setup.k_e * setup.factor,
                                 k_q=setup.k_q * setup.factor, **extra)


def reach(thickness: np.ndarray) -> tuple[int, int, int]:
    """(head, snout, centre row) of the glacier: first and last column whose centre row holds at
    least ``SNOUT_ICE_M`` of ice."""
    centre = thickness.shape[0] // 2
    iced = np.flatnonzero(thickness[centre - 1: centre + 1].max(axis=0) >= SNOUT_ICE_M)
    if iced.size == 0:
        return 0, 0, centre
    return int(iced[0]), int(iced[-1]), centre


def middle_columns(thickness: np.ndarray) -> np.ndarray:
    """Columns between 25 % and 75 % of the way from the glacier's head to its snout."""
    head, snout, _ = reach(thickness)
    lo, hi = head + 0.25 * (snout - head), head + 0.75 * (snout - head)
    return np.arange(int(math.ceil(lo)), int(math.floor(hi)) + 1)


def section_fit(bed: np.ndarray, col: int, valley: Valley,
                half_width: float | None = None) -> tuple[float, float, float, float, float]:
    """``fit_power_law`` of column ``col`` within ``half_width`` (m; default: the walls' tops) of
    the valley's axis: (b, a, y0, z0, rmse)."""
    y = (np.arange(bed.shape[0]) - (bed.shape[0] - 1) / 2) * valley.dx
    inside = np.abs(y) <= (valley.wall_half_width if half_width is None else half_width) + 1e-9
    return fit_power_law(y[inside], bed[inside, col])


def exponents(bed: np.ndarray, cols: np.ndarray, valley: Valley,
              half_widths: np.ndarray | None = None) -> np.ndarray:
    """b of each column of ``cols`` (``section_fit``), within ``half_widths`` (m, one per column)."""
    widths = [None] * len(cols) if half_widths is None else half_widths
    return np.array([section_fit(bed, int(c), valley, w)[0] for c, w in zip(cols, widths, strict=True)])


def trough_half_widths(state: coupled.GlacierState, cols: np.ndarray, valley: Valley) -> np.ndarray:
    """Half-width (m) of the trough that the trunk glacier fills in each column of ``cols``: where
    the initial 30° walls reach the ice surface above the axis (at least 4 cells)."""
    centre = state.bed.shape[0] // 2
    depth = state.thickness[centre - 1: centre + 1, cols].max(axis=0)
    width = depth / math.tan(math.radians(WALL_DEG))
    return np.clip(width, 4.0 * valley.dx, valley.wall_half_width)


def zones(bed0: np.ndarray, thickness: np.ndarray, cols: np.ndarray, valley: Valley) -> dict[str, np.ndarray]:
    """bool[ny, nx] masks over ``cols``: the floor (|y| ≤ 2 cells), the lower walls (ice ≥ 60 m
    off the floor) and the wall films (0 < ice < 60 m on the 30° walls)."""
    ny, nx = bed0.shape
    y = np.abs(np.arange(ny) - (ny - 1) / 2)[:, None] * valley.dx * np.ones((1, nx))
    in_cols = np.zeros((ny, nx), dtype=bool)
    in_cols[:, cols] = True
    walls = in_cols & (y > 2.0 * valley.dx) & (y <= valley.wall_half_width)
    return {"floor": in_cols & (y <= 2.0 * valley.dx),
            "lower walls": walls & (thickness >= 60.0),
            "wall films": walls & (thickness > 0.0) & (thickness < 60.0)}


def diagnose(state: coupled.GlacierState, grid: Grid, params: coupled.CoupledParams, cols: np.ndarray,
             bed0: np.ndarray, valley: Valley, label: str) -> dict:
    """Ice, sliding and erosion across a middle section and by zone (printed and returned)."""
    flow = coupled.flow_field(state.bed, state.thickness, grid, params, warm=state.lattice)
    ub, vb = flow.basal
    speed = np.hypot(ub, vb)
    tight = None
    if params.iceflow == "blatter":  # the same geometry solved to a residual of 1e-4
        tight = coupled.flow_field(state.bed, state.thickness, grid, params, warm=flow.lattice, rtol=1e-4,
                                   max_iter=5000, energy_rtol=0.0)
        iced = state.thickness > 1.0
        tight_speed = np.hypot(*tight.basal)
        l2 = float(np.linalg.norm((speed - tight_speed)[iced]) / np.linalg.norm(tight_speed[iced]))
    abr, qua = erosion.erosion_rates(state.bed, ub, vb, grid, params.k_e, params.abrasion_exponent,
                                     params.k_q, params.boundary, surface=state.bed + state.thickness,
                                     adverse_slope_ratio=params.adverse_slope_ratio)
    zx, zy = erosion.downward_gradient(state.bed, grid)
    q_focus = erosion.quarrying_focus(ub, vb, zx, zy)
    col = int(cols[len(cols) // 2])
    ny = state.bed.shape[0]
    rows = list(range(max(ny // 2 - 18, 0), min(ny // 2 + 19, ny), 3))
    table = {"row": rows, "bed_above_floor_m": [], "ice_m": [], "sliding_m_y": [], "surface_m_y": [],
             "Q": [], "abrasion_mm_y": [], "quarrying_mm_y": []}
    us = np.hypot(*flow.surface)
    if tight is not None:
        table["sliding_tight_m_y"] = [round(float(tight_speed[r, col]), 1) for r in rows]
    for r in rows:
        table["bed_above_floor_m"].append(round(float(state.bed[r, col] - state.bed[:, col].min()), 1))
        table["ice_m"].append(round(float(state.thickness[r, col]), 1))
        table["sliding_m_y"].append(round(float(speed[r, col]), 1))
        table["surface_m_y"].append(round(float(us[r, col]), 1))
        table["Q"].append(round(float(q_focus[r, col]), 2))
        table["abrasion_mm_y"].append(round(float(-abr[r, col]) * 1e3, 3))
        table["quarrying_mm_y"].append(round(float(-qua[r, col]) * 1e3, 3))
    by_zone = {}
    for name, mask in zones(bed0, state.thickness, cols, valley).items():
        if not mask.any():
            continue
        by_zone[name] = {"cells": int(mask.sum()), "ice_m": float(np.mean(state.thickness[mask])),
                         "sliding_m_y": float(np.mean(speed[mask])), "Q": float(np.mean(q_focus[mask])),
                         "abrasion_mm_y": float(-np.mean(abr[mask]) * 1e3),
                         "quarrying_mm_y": float(-np.mean(qua[mask]) * 1e3)}
    iced = np.zeros(state.bed.shape, dtype=bool)
    iced[:, cols] = state.thickness[:, cols] > 1.0
    erodes = erosion.adverse_slope_erodes(state.bed, state.bed + state.thickness, ub, vb, grid,
                                          params.adverse_slope_ratio, params.boundary)
    by_zone["adverse-slope rule"] = {"ice_cells": int(iced.sum()), "not_eroded": int((iced & ~erodes).sum())}
    out = {"label": label, "column": col, "section": table, "zones": by_zone,
           "solve": {"iterations": flow.iterations, "residual": flow.residual}}
    if tight is not None:
        out["tight_solve"] = {"iterations": tight.iterations, "residual": tight.residual,
                              "sliding_rel_l2_vs_run": l2}
        print(f"  run's solve residual {flow.residual:.3g}; re-solved to {tight.residual:.2g} in "
              f"{tight.iterations} iterations: sliding differs by {100 * l2:.1f} % (relative L2, ice > 1 m)")
    print(f"--- {label}: column {col} (rates with k_e, k_q × F = {params.k_e:.3g}, {params.k_q:.3g})")
    for key, values in table.items():
        print(f"{key:>18s} " + " ".join(f"{v:7g}" for v in values))
    for name, z in by_zone.items():
        print(f"{name:>18s} " + ", ".join(f"{k} {v:.3g}" for k, v in z.items()))
    return out


def experiment(setup: Setup, diagnose_sections: bool = False) -> dict:
    """Spin up, erode, measure (module docstring). Returns the measures and the fields."""
    valley = setup.valley
    bed0 = valley.bed()
    grid = Grid.full(bed0.shape, valley.dx)
    cnn = None
    if setup.iceflow == "cnn":
        from unerode_cli.glacier import cnn_iceflow

        cnn = cnn_iceflow.CnnIceflow(seed=setup.seed)
    started = time.perf_counter()
    spin = coupled.run(coupled.GlacierState(bed0, np.zeros_like(bed0)), grid,
                       _params(setup, grid, False, cnn), valley.ela,
                       coupled.step_times(setup.spinup_years, setup.dt))
    spun = spin.state
    cols = middle_columns(spun.thickness)
    head, snout, _ = reach(spun.thickness)
    params = _params(setup, grid, True, cnn)
    out: dict = {"setup": _as_dict(setup), "head_col": head, "snout_col": snout,
                 "middle_cols": [int(cols[0]), int(cols[-1])] if cols.size else [],
                 "spinup_volume_km3": coupled.ice_volume(spun.thickness, grid) / 1e9,
                 "spinup_max_ice_m": float(spun.thickness.max()),
                 "spinup_seconds": time.perf_counter() - started,
                 "spinup_unconverged_solves": spin.unconverged,
                 "spinup_cnn": [spin.cnn_solves, spin.cnn_takeovers]}
    out["b_before"] = exponents(bed0, cols, valley).tolist()
    trough = trough_half_widths(spun, cols, valley)
    out["trough_half_width_m"] = [float(np.min(trough)), float(np.max(trough))]
    out["b_trough_before"] = exponents(bed0, cols, valley, trough).tolist()
    diagnostics = []
    if diagnose_sections:
        diagnostics.append(diagnose(spun, grid, params, cols, bed0, valley, "after spin-up"))
    series = [{"years": 0.0, "eroding_years": 0.0, "median_b": float(np.median(out["b_before"])),
               "median_b_trough": float(np.median(out["b_trough_before"]))}]
    max_ice = spun.thickness.copy()

    kept = [spun]
    cnn_counts = [0, 0]  # solves in which the network predicted, and takeovers among them

    def on_step(state: coupled.GlacierState, report: coupled.StepReport) -> None:
        np.maximum(max_ice, state.thickness, out=max_ice)
        kept[0] = state
        cnn_counts[0] += report.flow.takeover is not None
        cnn_counts[1] += bool(report.flow.takeover)
        years = state.time - setup.spinup_years
        if abs(years / setup.snapshot_every - round(years / setup.snapshot_every)) < 1e-6:
            b = float(np.median(exponents(state.bed, cols, valley)))
            bt = float(np.median(exponents(state.bed, cols, valley, trough)))
            series.append({"years": years, "eroding_years": years * setup.factor, "median_b": b,
                           "median_b_trough": bt,
                           "max_lowering_m": float(np.max(bed0 - state.bed)),
                           "max_ice_m": float(state.thickness.max()),
                           "volume_km3": coupled.ice_volume(state.thickness, grid) / 1e9,
                           "cnn_solves": cnn_counts[0], "cnn_takeovers": cnn_counts[1],
                           "seconds": time.perf_counter() - started})
            print(f"  t = {years:6.0f} y (×F = {years * setup.factor:7.0f} y): median b {b:.3f} "
                  f"(trough {bt:.3f}), "
                  f"lowered ≤ {np.max(bed0 - state.bed):.0f} m, ice ≤ {state.thickness.max():.0f} m "
                  f"({series[-1]['volume_km3']:.3f} km³), "
                  + (f"CNN taken over in {cnn_counts[1]} of {cnn_counts[0]} solves, " if cnn else "")
                  + f"{time.perf_counter() - started:.0f} s", flush=True)

    stops = np.arange(setup.snapshot_every, setup.years, setup.snapshot_every)
    times = setup.spinup_years + coupled.step_times(setup.years, setup.dt, stops)
    final, diverged = spun, None
    ela: coupled.Ela = valley.ela
    if setup.ela_end is not None:
        ela = coupled.ElaTable(np.array([setup.spinup_years, setup.spinup_years + setup.years]),
                               np.array([valley.ela, setup.ela_end]))
    try:
        result = coupled.run(spun, grid, params, ela, times, on_step=on_step)
        final = result.state
        out["unconverged_solves"] = result.unconverged
    except (coupled.Diverged, FloatingPointError, coupled.TooManySubsteps) as error:
        diverged = str(error)
        final = kept[0]  # the last state reached before the divergence
        print("  stopped:", diverged)
    out["diverged"] = diverged
    out["cnn"] = list(cnn_counts)
    out["series"] = series
    out["final_years"] = final.time - setup.spinup_years
    last = final
    if last is not None:
        out["b_after"] = exponents(last.bed, cols, valley).tolist()
        out["b_trough_after"] = exponents(last.bed, cols, valley, trough).tolist()
        out["max_lowering_m"] = float(np.max(bed0 - last.bed))
        out["floor_lowering_m"] = float(np.mean(bed0[len(bed0) // 2, cols] - last.bed[len(bed0) // 2, cols]))
        if diagnose_sections:
            diagnostics.append(diagnose(last, grid, params, cols, bed0, valley, "at the end"))
    out["median_b_before"] = float(np.median(out["b_before"]))
    out["median_b_after"] = float(np.median(out["b_after"])) if "b_after" in out else float("nan")
    out["median_b_trough_before"] = float(np.median(out["b_trough_before"]))
    out["median_b_trough_after"] = (float(np.median(out["b_trough_after"])) if "b_trough_after" in out
                                    else float("nan"))
    out["diagnostics"] = diagnostics
    out["seconds"] = time.perf_counter() - started
    out["fields"] = {"bed0": bed0, "spun": spun, "final": final, "max_ice": max_ice, "cols": cols}
    return out


def _as_dict(setup: Setup) -> dict:
    d = dataclasses.asdict(setup)
    d["k_e_used"] = setup.k_e * setup.factor
    d["k_q_used"] = setup.k_q * setup.factor
    return d


def plot(outcome: dict, out_dir: Path, tag: str = "") -> list[Path]:
    """The before/after sections and the map (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f = outcome["fields"]
    valley = Valley(**outcome["setup"]["valley"])
    bed0, spun, final, cols = f["bed0"], f["spun"], f["final"], f["cols"]
    y = (np.arange(bed0.shape[0]) - (bed0.shape[0] - 1) / 2) * valley.dx
    picks = [int(cols[0]), int(cols[len(cols) // 2]), int(cols[-1])]
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), sharey=False)
    for ax, col in zip(axes, picks, strict=True):
        floor = bed0[:, col].min()
        ax.plot(y, bed0[:, col] - floor, "k--", lw=1, label="bed before")
        ax.fill_between(y, spun.bed[:, col] - floor, spun.bed[:, col] + spun.thickness[:, col] - floor,
                        color="#9ecae1", alpha=0.5, label="ice after spin-up")
        ax.plot(y, final.bed[:, col] - floor, "C3", lw=1.5,
                label="bed after" if outcome["diverged"] is None else "bed before the divergence")
        ice = final.thickness[:, col]
        top = np.where(ice > 1.0, final.bed[:, col] + ice - floor, np.nan)
        ax.plot(y, top, color="#3182bd", lw=0.8, label="ice surface at the end")
        b, a, y0, z0, _ = section_fit(final.bed, col, valley)
        inside = np.abs(y) <= valley.wall_half_width
        ax.plot(y[inside], z0 + a * np.abs(y[inside] - y0) ** b - floor, "C3:", lw=1,
                label=f"fit after, b = {b:.2f}")
        b0 = section_fit(bed0, col, valley)[0]
        ax.set_title(f"x = {col * valley.dx / 1000:.2f} km (b before {b0:.2f})")
        ax.set_xlabel("distance across the valley (m)")
        ax.set_xlim(-1.3 * valley.wall_half_width, 1.3 * valley.wall_half_width)
        deepest = float(np.min(final.bed[:, col] - floor))
        ax.set_ylim(max(deepest - 20.0, -valley.relief), valley.relief * 1.15)
        if deepest < -valley.relief:
            ax.text(0.5, 0.02, f"bed cut to {deepest:.3g} m (off the axis)", transform=ax.transAxes,
                    ha="center", fontsize=8, color="C3")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("elevation above the initial floor (m)")
    axes[0].legend(fontsize=8, loc="upper center")
    s = outcome["setup"]
    fig.suptitle(f"{s['iceflow']}: median b {outcome['median_b_before']:.2f} → "
                 f"{outcome['median_b_after']:.2f} after {outcome['final_years']:.0f} y "
                 f"× F = {s['factor']:g} "
                 f"(k_e {s['k_e_used']:.2g}, k_q {s['k_q_used']:.2g})"
                 + ("\n" + outcome["diverged"] if outcome["diverged"] else ""), fontsize=10)
    fig.tight_layout()
    paths = [out_dir / f"u_valley_sections{tag}.png"]
    fig.savefig(paths[0], dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(10, 5))
    lowered = bed0 - final.bed
    extent = (0, bed0.shape[1] * valley.dx / 1000, bed0.shape[0] * valley.dx / 1000, 0)
    top = float(np.percentile(lowered, 99.5))  # a few runaway cells (SIA) would hide the rest
    im = ax.imshow(lowered, cmap="magma_r", extent=extent, vmin=0.0, vmax=max(top, 1.0))
    label = "bed lowered (m)" + (f"; deepest {lowered.max():.3g} m" if lowered.max() > 1.5 * top else "")
    fig.colorbar(im, ax=ax, label=label, shrink=0.8, extend="max" if lowered.max() > top else "neither")
    ax.contour(np.arange(bed0.shape[1]) * valley.dx / 1000 + valley.dx / 2000,
               np.arange(bed0.shape[0]) * valley.dx / 1000 + valley.dx / 2000, f["max_ice"],
               levels=[1.0, 100.0], colors=["#3182bd", "#08519c"], linewidths=[0.8, 1.2])
    for col in (cols[0], cols[-1]):
        ax.axvline((col + 0.5) * valley.dx / 1000, color="w", ls="--", lw=0.8)
    ax.set_xlabel("x, down-valley (km)")
    ax.set_ylabel("y (km)")
    ax.set_title(f"{s['iceflow']}: bed lowering; ice outline (1 m, 100 m, at its largest); "
                 "middle reach between the dashed lines", fontsize=9)
    fig.tight_layout()
    paths.append(out_dir / f"u_valley_map{tag}.png")
    fig.savefig(paths[1], dpi=110)
    plt.close(fig)
    return paths


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--iceflow", default="blatter", choices=("blatter", "sia", "cnn"))
    ap.add_argument("--seed", type=int, default=Setup.seed, help="the CNN's weights (--iceflow cnn)")
    ap.add_argument("--factor", type=float, default=Setup.factor)
    ap.add_argument("--years", type=float, default=Setup.years)
    ap.add_argument("--spinup", type=float, default=Setup.spinup_years)
    ap.add_argument("--dt", type=float, default=20.0)
    ap.add_argument("--ela", type=float, default=Valley.ela)
    ap.add_argument("--k-e", type=float, default=TABLE1_K_E)
    ap.add_argument("--k-q", type=float, default=TABLE1_K_Q)
    ap.add_argument("--snow-slopes", type=float, nargs=2, default=None)
    ap.add_argument("--sliding-c", type=float, default=None)
    ap.add_argument("--ela-end", type=float, default=COOLED_ELA)
    ap.add_argument("--constant-ela", action="store_true", help="keep the spin-up's ELA while eroding")
    ap.add_argument("--frozen-above", type=float, default=None)
    ap.add_argument("--shape", type=int, nargs=2, default=(Valley.ny, Valley.nx))
    ap.add_argument("--dx", type=float, default=Valley.dx)
    ap.add_argument("--relief", type=float, default=Valley.relief)
    ap.add_argument("--snapshot-every", type=float, default=100.0)
    ap.add_argument("--diagnose", action="store_true")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--tag", default="")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    valley = Valley(ny=args.shape[0], nx=args.shape[1], dx=args.dx, ela=args.ela, relief=args.relief)
    setup = Setup(valley=valley, iceflow=args.iceflow, factor=args.factor, k_e=args.k_e, k_q=args.k_q,
                  spinup_years=args.spinup, years=args.years, dt=args.dt, snapshot_every=args.snapshot_every,
                  snow_slopes=tuple(args.snow_slopes) if args.snow_slopes else None,
                  sliding_c=args.sliding_c, ela_end=None if args.constant_ela else args.ela_end,
                  frozen_above=args.frozen_above, seed=args.seed)
    outcome = experiment(setup, args.diagnose)
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        for path in plot(outcome, args.out, args.tag):
            print("wrote", path)
    report = {k: v for k, v in outcome.items() if k != "fields"}
    print(json.dumps({k: report[k] for k in ("head_col", "snout_col", "middle_cols", "spinup_max_ice_m",
                                            "median_b_before", "median_b_after", "median_b_trough_before",
                                            "median_b_trough_after", "diverged", "cnn", "spinup_cnn",
                                            "seconds")}))
    if args.json is not None:
        args.json.write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
