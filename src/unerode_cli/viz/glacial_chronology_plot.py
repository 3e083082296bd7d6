"""The chronology of a glacial run as a PNG: the climate proxy, the ELA it gives and the ice
volume of the run, one above the other against age (001 Fig. 6's forcing and response)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def save_glacial_chronology_plot(path: Path, proxy_ages_ka: np.ndarray, proxy: np.ndarray, proxy_label: str,
                                 ages_ka: np.ndarray, ela_m: np.ndarray, ice_volume_m3: np.ndarray,
                                 title: str = "") -> None:
    """Write a three-panel PNG against age (ka, the past to the right): the proxy over the run's
    ages (a δ18O axis reversed so that warm is up), the ELA (m) and the ice volume (km³), the
    last two at the ``ages_ka`` of the run."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    low, high = float(np.min(ages_ka)), float(np.max(ages_ka))
    fig, (top, middle, bottom) = plt.subplots(3, 1, figsize=(9, 7), sharex=True)
    inside = (proxy_ages_ka >= low - 1e-9) & (proxy_ages_ka <= high + 1e-9)
    top.plot(proxy_ages_ka[inside], proxy[inside], color="k", lw=1)
    top.set_ylabel(proxy_label)
    if "18" in proxy_label:
        top.invert_yaxis()
    middle.plot(ages_ka, ela_m, color="#a50f15", lw=1.2)
    middle.set_ylabel("ELA (m)")
    bottom.plot(ages_ka, np.asarray(ice_volume_m3) / 1e9, color="#08519c", lw=1.2)
    bottom.set_ylabel("ice volume (km³)")
    bottom.set_xlabel("age (ka)")
    bottom.set_xlim(low, high if high > low else low + 1e-3)
    if title:
        top.set_title(title)
    for ax in (top, middle, bottom):
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)
