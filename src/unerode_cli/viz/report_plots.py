"""Plots that reports draw from a run's tables (e.g. a climate-run's timeline)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import BinaryIO

import numpy as np


def save_series_panels(path: Path | BinaryIO, x: np.ndarray, xlabel: str,
                       panels: Sequence[tuple[str, Mapping[str, np.ndarray]]], title: str = "") -> None:
    """Write a PNG of stacked panels sharing the x axis: each panel is (y label, legend → values
    at ``x``), e.g. the sea level and the cumulative eroded and deposited volumes of a run
    against age."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(panels), 1, figsize=(9, 2.2 * len(panels) + 0.7), sharex=True,
                             squeeze=False)
    order = np.argsort(x)
    for ax, (ylabel, series) in zip(axes[:, 0], panels, strict=True):
        for name, values in series.items():
            ax.plot(x[order], np.asarray(values)[order], lw=1.3, label=name)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        if len(series) > 1:
            ax.legend(fontsize=8, loc="best")
    axes[-1, 0].set_xlabel(xlabel)
    if title:
        axes[0, 0].set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100, format="png")
    plt.close(fig)
