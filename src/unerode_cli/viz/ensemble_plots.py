"""Plots of an ensemble: each swept parameter against the members' scores."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import BinaryIO


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
            ax.set_xscale("log")
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100, format="png")
    plt.close(fig)


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)
