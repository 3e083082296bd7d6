"""Plots of an ensemble: each swept parameter against the members' scores, and every pair of
swept parameters with the members coloured by their score."""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from pathlib import Path
from typing import BinaryIO

import numpy as np


def save_scatter(path: Path | BinaryIO, parameter: str, values: Sequence[object],
                 scores: Mapping[str, Sequence[float | None]], log_x: bool = False,
                 best: int | None = None) -> None:
    """Write a PNG with one panel per score (its label, e.g. "terrace RMSE (m)", → one score
    per member, None when missing): the score against the member's value of ``parameter``.
    Text or true/false values are categories along x; ``log_x`` draws numbers on a log axis;
    ``best`` (an index into ``values``) is marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    categories = sorted({str(v) for v in values}) if not all(_is_number(v) for v in values) else None
    x = [categories.index(str(v)) if categories else float(v) for v in values]  # type: ignore[arg-type]
    fig, axes = plt.subplots(1, len(scores), figsize=(4.2 * len(scores) + 0.4, 3.4), squeeze=False)
    for ax, (label, ys) in zip(axes[0], scores.items(), strict=True):
        shown = [(xi, y) for xi, y in zip(x, ys, strict=True) if y is not None and math.isfinite(y)]
        ax.scatter([p[0] for p in shown], [p[1] for p in shown], s=18, color="#3182bd", alpha=0.8)
        if best is not None and ys[best] is not None:
            ax.scatter([x[best]], [ys[best]], s=60, facecolors="none", edgecolors="#d62728", lw=1.5,
                       label="best member")
            ax.legend(fontsize=8, loc="best")
        ax.set_xlabel(parameter)
        ax.set_ylabel(label)
        if categories:
            ax.set_xticks(range(len(categories)))
            ax.set_xticklabels([Path(c).name for c in categories], rotation=15, fontsize=8)
            ax.set_xlim(-0.5, len(categories) - 0.5)
        elif log_x:
            log_axis(ax.xaxis, x, ax.set_xscale)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100, format="png")
    plt.close(fig)


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def axis_positions(values: Sequence[object]) -> tuple[np.ndarray, list[str] | None]:
    """Where each member's value lies along a plot axis: numbers as they are, and categories
    (text, true/false) at 0, 1, 2 … in sorted order, each member spread ±0.3 around its
    category (in member order) so that members sharing a category stay apart. Returns
    (positions float[n], the categories or None)."""
    if all(_is_number(v) for v in values):
        return np.array([float(v) for v in values]), None  # type: ignore[arg-type]
    categories = sorted({str(v) for v in values})
    index = np.array([categories.index(str(v)) for v in values], dtype=np.float64)
    positions = index.copy()
    for k in range(len(categories)):
        members = np.flatnonzero(index == k)
        if members.size > 1:
            positions[members] += 0.6 * (np.arange(members.size) / (members.size - 1) - 0.5)
    return positions, categories


def log_axis(axis, values: Sequence[float] | np.ndarray, set_scale) -> None:
    """A log axis with three ticks spread over ``values`` (numbers, 2 significant digits) and no
    minor labels, readable also over less than a decade (e.g. K from 1e-5 to 4e-5)."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

    set_scale("log")
    positive = np.asarray([v for v in values if v > 0], dtype=np.float64)
    if positive.size:
        ticks = np.unique(np.geomspace(positive.min(), positive.max(), 3))
        axis.set_major_locator(FixedLocator(ticks))
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.2g}"))
        axis.set_minor_formatter(NullFormatter())


def _category_axis(axis, categories: list[str], set_limits) -> None:
    axis.set_ticks(range(len(categories)))
    axis.set_ticklabels([_short_name(c) for c in categories], fontsize=7)
    set_limits(-0.5, len(categories) - 0.5)


def _short_name(text: str, width: int = 16) -> str:
    name = Path(text).name or text
    return name if len(name) <= width else name[: width - 1] + "…"


def save_pair_matrix(path: Path | BinaryIO, parameters: Mapping[str, Sequence[object]], score_label: str,
                     scores: Sequence[float | None], log_keys: Collection[str] = (),
                     best: int | None = None) -> None:
    """Write a PNG scatter matrix of the swept ``parameters`` (name → one value per member, k ≥ 2
    names): below the diagonal, panel (i, j) shows parameter j (x) against parameter i (y),
    each member a dot coloured by its score (``scores``, lower is better; a member without a
    score is a grey cross); on the diagonal, the score against parameter i. Categories lie along
    an axis as :func:`axis_positions` places them, names in ``log_keys`` on log axes; ``best``
    (an index into the members) is circled in red. One colour bar, labelled ``score_label``.

    Kept whole: one figure, its panels laid out in one pass."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import Normalize

    names = list(parameters)
    k = len(names)
    axes_of = {name: axis_positions(parameters[name]) for name in names}
    score = np.array([s if s is not None and math.isfinite(s) else np.nan for s in scores], dtype=np.float64)
    scored = np.isfinite(score)
    norm = Normalize(*(np.nanmin(score), np.nanmax(score)) if scored.any() else (0.0, 1.0))
    fig, grid = plt.subplots(k, k, figsize=(2.6 * k + 1.6, 2.6 * k + 0.6), squeeze=False,
                             layout="constrained")
    order = np.flatnonzero(scored)[np.argsort(-score[scored], kind="stable")]  # the best drawn last, on top
    for i, y_name in enumerate(names):
        for j, x_name in enumerate(names):
            ax = grid[i, j]
            if j > i:
                ax.set_axis_off()
                continue
            x, x_categories = axes_of[x_name]
            y, y_categories = (score, None) if i == j else axes_of[y_name]
            ax.scatter(x[order], y[order], c=score[order], cmap="viridis_r", norm=norm, s=24,
                       edgecolors="k", linewidths=0.3)
            ax.scatter(x[~scored], y[~scored], marker="x", color="0.6", s=18)
            if best is not None and (i != j or scored[best]):
                ax.scatter([x[best]], [y[best]], s=90, facecolors="none", edgecolors="#d62728", lw=1.5)
            if x_categories:
                _category_axis(ax.xaxis, x_categories, ax.set_xlim)
            elif x_name in log_keys:
                log_axis(ax.xaxis, x, ax.set_xscale)
            if y_categories:
                _category_axis(ax.yaxis, y_categories, ax.set_ylim)
            elif i != j and y_name in log_keys:
                log_axis(ax.yaxis, y, ax.set_yscale)
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
            if i == k - 1 or i == j:
                ax.set_xlabel(x_name, fontsize=8)
            ax.set_ylabel(score_label if i == j else (y_name if j == 0 else ""), fontsize=8)
    bar = fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap="viridis_r"), ax=grid.ravel().tolist(),
                       shrink=0.6)
    bar.set_label(f"{score_label}, lower is better", fontsize=8)
    fig.savefig(path, dpi=90, format="png")
    plt.close(fig)
