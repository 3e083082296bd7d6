"""A contact sheet: several images (previews of runs) side by side on one PNG, each under its
title, in rows of ``columns`` panels, read left to right and top to bottom."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

#: Width of a panel (inches) and the resolution of the sheet (dots per inch).
PANEL_WIDTH = 4.0
DPI = 110
#: Height (inches) of a panel's title line and of the sheet's title.
TITLE_HEIGHT = 0.35


def sheet_layout(count: int, columns: int | None = None) -> tuple[int, int]:
    """(rows, columns) of a sheet of ``count`` ≥ 1 panels: ``columns`` as given (at most
    ``count``), else the smallest square-ish grid, ⌈√count⌉ columns."""
    if count < 1:
        raise ValueError("a contact sheet needs at least one image")
    if columns is not None and columns < 1:
        raise ValueError(f"a contact sheet needs at least one column, not {columns}")
    columns = min(count, columns or math.ceil(math.sqrt(count)))
    return math.ceil(count / columns), columns


def save_contact_sheet(path: Path, images: Sequence[np.ndarray], titles: Sequence[str],
                       columns: int | None = None, title: str = "") -> None:
    """Write a PNG of the ``images`` (arrays ``(H, W)``, ``(H, W, 3)`` or ``(H, W, 4)``, as
    ``matplotlib.image.imread`` gives them) in a grid (``sheet_layout``), each panel
    ``PANEL_WIDTH`` inches wide and each row as tall as its tallest image needs, with each
    image's title above it; ``title`` heads the sheet. ValueError when the titles do not match
    the images."""
    if len(images) != len(titles):
        raise ValueError(f"{len(images)} images but {len(titles)} titles")
    rows, columns = sheet_layout(len(images), columns)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    aspects = [image.shape[0] / image.shape[1] for image in images]
    heights = [PANEL_WIDTH * max(aspects[r * columns:(r + 1) * columns]) + TITLE_HEIGHT for r in range(rows)]
    fig, axes = plt.subplots(rows, columns, figsize=(columns * PANEL_WIDTH, sum(heights)
                                                     + (TITLE_HEIGHT if title else 0.0)),
                             squeeze=False, gridspec_kw={"height_ratios": heights})
    for ax in axes.ravel():
        ax.set_axis_off()
    for ax, image, name in zip(axes.ravel(), images, titles, strict=False):  # spare panels stay blank
        ax.imshow(image, cmap="gray" if image.ndim == 2 else None, interpolation="antialiased")
        ax.set_title(name, fontsize=10)
    if title:
        fig.suptitle(title, fontsize=12)
    fig.tight_layout()
    fig.savefig(path, dpi=DPI, format="png")
    plt.close(fig)
