"""Flow directions as the ESRI D8 pointer codes GIS tools read (ArcGIS, TauDEM, WhiteboxTools)."""

from __future__ import annotations

import numpy as np

#: ESRI code of each neighbour offset (drow, dcol): E 1, SE 2, S 4, SW 8, W 16, NW 32, N 64, NE 128.
ESRI_CODES = {(0, 1): 1, (1, 1): 2, (1, 0): 4, (1, -1): 8, (0, -1): 16, (-1, -1): 32,
              (-1, 0): 64, (-1, 1): 128}


def esri_d8_codes(receivers: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """uint8[ny, nx] ESRI D8 code of each cell's receiver; 0 where ``receivers`` is −1.

    ``receivers`` holds the flat (row-major) index of each cell's receiver, −1 for none, for
    a grid of ``shape``.
    """
    ny, nx = shape
    receivers = np.asarray(receivers).reshape(shape)
    rows, cols = np.indices((ny, nx))
    has = receivers >= 0
    drow = np.where(has, receivers // nx - rows, 0)
    dcol = np.where(has, receivers % nx - cols, 0)
    codes = np.zeros((ny, nx), dtype=np.uint8)
    for (dr, dc), code in ESRI_CODES.items():
        codes[has & (drow == dr) & (dcol == dc)] = code
    return codes
