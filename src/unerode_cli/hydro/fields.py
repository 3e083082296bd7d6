"""Scalar-or-raster fields as the flat arrays the kernels read."""

from __future__ import annotations

import numpy as np


def flat_field(value: float | np.ndarray, shape: tuple[int, int], name: str) -> np.ndarray:
    """A scalar as float64[1], or a raster of ``shape`` as a flat C-contiguous float64 array.

    Kernels read element ``i`` of a field of size > 1 and element 0 otherwise.
    """
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        return arr.reshape(1)
    if arr.shape != tuple(shape):
        raise ValueError(f"{name} has shape {arr.shape}, the grid has {tuple(shape)}")
    return np.ascontiguousarray(arr).ravel()
