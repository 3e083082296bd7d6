"""Hypsometry curves of one or more terrains on one plot (like 001 Fig. 15)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

AXIS_LABELS = {
    "max": "elevation / highest elevation",
    "range": "relative elevation (h − min)/(max − min)",
    "none": "elevation (m)",
}


def save_hypsometry_plot(
    path: Path,
    curves: list[tuple[str, np.ndarray, np.ndarray]],
    normalise: str,
    title: str = "",
) -> None:
    """Write a PNG with one histogram line per terrain: ``curves`` holds (label, bin centres,
    fraction of the area per bin); the elevation axis is vertical, as in 001 Fig. 15."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 6))
    for label, centres, fraction in curves:
        ax.plot(fraction * 100.0, centres, lw=1.6, label=label)
    ax.set_xlabel("share of the area (%)")
    ax.set_ylabel(AXIS_LABELS[normalise])
    ax.set_xlim(left=0.0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)
