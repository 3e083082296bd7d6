"""Plots of a terrace comparison: long profiles of past riverbeds with the dated terraces
(like 000 Fig. 12), incision rates per period (like 000 Fig. 13), and the spread across the
members of an ensemble of the simulated height at each terrace."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np

OBSERVED, SIMULATED = "#e6550d", "#3182bd"


@dataclass(frozen=True)
class Levels:
    """Observed levels (one value per observation): age (ka), chainage (m, NaN = the whole
    river), observed and simulated height above the present river (m), uncertainty (m, NaN =
    none)."""

    age_ka: np.ndarray
    chainage_m: np.ndarray
    observed_m: np.ndarray
    simulated_m: np.ndarray
    uncertainty_m: np.ndarray


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _age_axis(ax, ylabel: str) -> None:
    """Age (ka) along x with the past to the left, a legend and a light grid."""
    ax.set_xlabel("age (ka)")
    ax.set_ylabel(ylabel)
    ax.invert_xaxis()
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)


def _save(plt, fig, path: Path) -> None:
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def save_profiles_plot(
    path: Path,
    chainage_m: np.ndarray,
    ages_ka: np.ndarray,
    heights_m: np.ndarray,
    levels: Levels,
    title: str = "",
) -> None:
    """Two panels: (top) height of the riverbed above today's along the river, one line per
    snapshot age, dated terraces as points with error bars in the colour of their age;
    (bottom) the same heights against age: the river's mean, the simulated value at each
    terrace and the observation."""
    plt = _pyplot()
    from matplotlib import cm
    from matplotlib.colors import Normalize

    oldest = max(float(np.max(ages_ka)), float(np.max(levels.age_ka, initial=0.0)), 1e-9)
    colour = cm.ScalarMappable(Normalize(0.0, oldest), "viridis_r")
    km = chainage_m / 1000.0
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 8))
    for age, profile in zip(ages_ka, heights_m, strict=True):
        top.plot(km, profile, color=colour.to_rgba(age), lw=1.4 if age > 0 else 0.8,
                 label=f"{age:g} ka")
    placed = np.isfinite(levels.chainage_m)
    errors = np.where(np.isfinite(levels.uncertainty_m), levels.uncertainty_m, 0.0)
    for k in np.flatnonzero(placed):
        top.errorbar(levels.chainage_m[k] / 1000.0, levels.observed_m[k], yerr=errors[k], fmt="o",
                     color=colour.to_rgba(levels.age_ka[k]), mec="k", capsize=3)
    top.set_xlabel("distance along the river from its downstream end (km)")
    top.set_ylabel("riverbed height above today's (m)")
    top.legend(fontsize=7, ncol=4, title="simulated bed at", title_fontsize=7)
    top.grid(alpha=0.3)
    fig.colorbar(colour, ax=top, label="age (ka)")

    means = np.nanmean(heights_m, axis=1)
    bottom.plot(ages_ka, means, "-s", color=SIMULATED, ms=4, label="simulated, mean along the river")
    bottom.plot(levels.age_ka, levels.simulated_m, "x", color=SIMULATED, ms=8, mew=2,
                label="simulated at the terrace")
    bottom.errorbar(levels.age_ka, levels.observed_m, yerr=errors, fmt="o", color=OBSERVED,
                    mec="k", capsize=3, label="observed terrace")
    _age_axis(bottom, "height above today's river (m)")
    if title:
        fig.suptitle(title)
    _save(plt, fig, path)


def save_incision_plot(
    path: Path,
    periods_ka: np.ndarray,
    observed: np.ndarray,
    uncertainty: np.ndarray,
    simulated: np.ndarray,
    intervals_ka: np.ndarray,
    interval_rates: np.ndarray,
    title: str = "",
) -> None:
    """Incision rates (mm/ka) against age (ka, the past to the left): the observed mean rate of
    each period (orange, ± uncertainty shaded), the simulated rate over the same period (blue
    dashed) and the simulated rate between consecutive snapshots (blue points).

    ``periods_ka`` and ``intervals_ka`` are float[k, 2] (older, younger) bounds."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for k, (old, young) in enumerate(periods_ka):
        ax.hlines(observed[k], young, old, color=OBSERVED, lw=3, label="observed" if k == 0 else None)
        if np.isfinite(uncertainty[k]):
            ax.fill_between([young, old], observed[k] - uncertainty[k], observed[k] + uncertainty[k],
                            color=OBSERVED, alpha=0.2, lw=0)
        ax.hlines(simulated[k], young, old, color=SIMULATED, lw=2, ls="--",
                  label="simulated, same period" if k == 0 else None)
    if len(intervals_ka):
        middle = intervals_ka.mean(axis=1)
        ax.plot(middle, interval_rates, "-o", color=SIMULATED, lw=0.8, ms=3,
                label="simulated, between snapshots")
    ax.axhline(0.0, color="0.5", lw=0.8)
    _age_axis(ax, "incision rate (mm/ka)")
    if title:
        ax.set_title(title)
    _save(plt, fig, path)


def save_terrace_spread_plot(
    path: Path | BinaryIO,
    labels: list[str],
    observed_m: np.ndarray,
    uncertainty_m: np.ndarray,
    members_m: np.ndarray,
    best_m: np.ndarray | None = None,
    title: str = "",
) -> None:
    """One column per dated terrace (``labels``, e.g. "young, 10 ka"): the simulated height of
    the past riverbed above today's river (m) of every member (grey dots, ``members_m``
    float[terraces, members], NaN where a member has none), their median (blue bar) and 5–95
    percentile range (blue line), the best member's value (red circle, ``best_m``
    float[terraces]) and the observed height with its uncertainty (orange, ``observed_m`` and
    ``uncertainty_m`` float[terraces], NaN = none)."""
    plt = _pyplot()
    count = len(labels)
    fig, ax = plt.subplots(figsize=(max(5.0, 1.3 * count + 2.5), 4.3))
    columns = np.arange(count, dtype=np.float64)
    spread = 0.5 * (np.arange(members_m.shape[1]) / max(members_m.shape[1] - 1, 1) - 0.5)
    for k in range(count):
        ax.scatter(columns[k] - 0.12 + 0.35 * spread, members_m[k], s=12, color="0.55", alpha=0.8,
                   label="members" if k == 0 else None, zorder=2)
    known = np.isfinite(members_m)
    filled = np.where(known, members_m, np.nan)
    has = known.any(axis=1)
    low, middle, high = (np.full(count, np.nan) for _ in range(3))
    if has.any():
        low[has], middle[has], high[has] = np.nanpercentile(filled[has], [5.0, 50.0, 95.0], axis=1)
    ax.vlines(columns + 0.12, low, high, color=SIMULATED, lw=2.5, label="members, 5–95 %", zorder=3)
    ax.hlines(middle, columns + 0.02, columns + 0.22, color=SIMULATED, lw=3, label="median member",
              zorder=4)
    if best_m is not None:
        ax.scatter(columns + 0.12, best_m, s=70, facecolors="none", edgecolors="#d62728", lw=1.5,
                   label="best member", zorder=5)
    errors = np.where(np.isfinite(uncertainty_m), uncertainty_m, 0.0)
    ax.errorbar(columns + 0.32, observed_m, yerr=errors, fmt="o", color=OBSERVED, mec="k", capsize=3,
                label="observed terrace", zorder=5)
    ax.set_xticks(columns + 0.1)
    ax.set_xticklabels(labels, fontsize=8)
    ax.set_xlim(-0.6, count - 0.3)
    ax.set_ylabel("height above today's river (m)")
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=7, loc="best")
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100, format="png")
    plt.close(fig)
