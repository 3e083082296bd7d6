"""Pictures of what the commands without a picture of their own compute, for the gallery.

``python plots.py info INFO.json OUT.png``: the footprint and elevation range that
``unerode-cli info --json`` reports. ``python plots.py screenshot PAGE.html OUT.png``: the top of
an HTML page (``unerode-cli report``) as headless Chromium renders it.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path


def info_plot(info_json: str, out_png: str) -> None:
    """Footprint of the raster in its CRS (size, cell size) and its elevations min/mean/max."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    info = json.loads(Path(info_json).read_text())
    ext, z = info["extent"], info["elevation_m"]
    fig, (ax, az) = plt.subplots(1, 2, figsize=(9, 4), gridspec_kw={"width_ratios": [3, 1]})
    ax.add_patch(plt.Rectangle((ext["left"], ext["bottom"]), ext["right"] - ext["left"],
                               ext["top"] - ext["bottom"], fill=False, lw=2))
    width, height = ext["right"] - ext["left"], ext["top"] - ext["bottom"]
    ax.set_xlim(ext["left"] - 0.1 * width, ext["right"] + 0.1 * width)
    ax.set_ylim(ext["bottom"] - 0.1 * height, ext["top"] + 0.1 * height)
    dx, dy = info["cell_size_m"]
    ax.set_title(f"{Path(info['file']).name}: {info['width']} × {info['height']} cells, "
                 f"{dx:.1f} m × {dy:.1f} m\n{info['crs']}; {info['nodata_cells']} nodata cells", fontsize=9)
    ax.set_xlabel("x (CRS units)")
    ax.set_ylabel("y (CRS units)")
    ax.set_aspect("equal")
    az.bar([0], [z["max"] - z["min"]], bottom=[z["min"]], width=0.5, color="0.8")
    az.axhline(z["mean"], color="C3", label=f"mean {z['mean']:.0f} m")
    az.set_xticks([])
    az.set_ylabel("elevation (m)")
    az.set_title(f"min {z['min']:.0f} m, max {z['max']:.0f} m", fontsize=9)
    az.legend(loc="lower center", fontsize=8)
    fig.tight_layout()
    fig.savefig(out_png, dpi=100)


def screenshot(page: str, out_png: str) -> None:
    """The top 1280 × 1400 pixels of an HTML page, rendered by headless Chromium."""
    browser = next((shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")
                    if shutil.which(n)), None)
    if browser is None:
        sys.exit("no headless browser (chromium) on the PATH")
    subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                    f"--screenshot={Path(out_png).resolve()}", "--window-size=1280,1400",
                    Path(page).resolve().as_uri()], check=True, capture_output=True, timeout=120)


if __name__ == "__main__":
    kind, *args = sys.argv[1:]
    {"info": info_plot, "screenshot": screenshot}[kind](*args)
