"""The chronology of a climate run as a PNG: the climate series with the phases shaded and the
sea level used by the run (like 000 Fig. 11)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

PHASE_COLOURS = {"glacial": "#9ecae1", "end-of-glacial": "#fdd0a2", "interglacial": "#c7e9c0"}


def save_chronology_plot(
    path: Path,
    ages_ka: np.ndarray,
    phases: np.ndarray,
    sea_level_m: np.ndarray,
    series_ages_ka: np.ndarray | None = None,
    series_values: np.ndarray | None = None,
    series_label: str = "",
    snapshots_ka: tuple[float, ...] = (),
    title: str = "",
) -> None:
    """Write a two-panel PNG: the input series (e.g. δ18O, ‰, axis reversed so that warm is up)
    and the run's sea level (m), both against age (ka, the past to the right), with a band
    per step coloured by its climate phase and the snapshot ages marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    order = np.argsort(ages_ka)
    ages, phase, sea = ages_ka[order], phases[order], sea_level_m[order]
    edges = np.concatenate([[ages[0]], (ages[1:] + ages[:-1]) / 2, [ages[-1]]]) if ages.size > 1 \
        else np.array([ages[0] - 0.5, ages[0] + 0.5])
    rows = 2 if series_values is not None else 1
    fig, axes = plt.subplots(rows, 1, figsize=(9, 2.6 * rows + 0.6), sharex=True, squeeze=False)
    for ax in axes[:, 0]:
        for k in range(ages.size):
            ax.axvspan(edges[k], edges[k + 1], color=PHASE_COLOURS.get(str(phase[k]), "#eeeeee"),
                       lw=0)
        for age in snapshots_ka:
            ax.axvline(age, color="0.3", lw=0.8, ls=":")
    if series_values is not None and series_ages_ka is not None:
        ax = axes[0, 0]
        inside = (series_ages_ka >= ages.min() - 1e-9) & (series_ages_ka <= ages.max() + 1e-9)
        ax.plot(series_ages_ka[inside], series_values[inside], color="k", lw=1)
        ax.set_ylabel(series_label)
        if "18" in series_label:
            ax.invert_yaxis()
    ax = axes[-1, 0]
    ax.plot(ages, sea, color="#08519c", lw=1.2)
    ax.set_ylabel("sea level (m)")
    ax.set_xlabel("age (ka)")
    ax.set_xlim(ages.min(), ages.max())
    handles = [Patch(color=c, label=p) for p, c in PHASE_COLOURS.items()]
    axes[0, 0].legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.8)
    if title:
        axes[0, 0].set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)
