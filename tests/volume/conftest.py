"""Shared helpers of the volume tests: particles on a jittered lattice, and mesh topology
checked from the faces alone."""

from __future__ import annotations

import numpy as np


def jittered_lattice(shape: tuple[int, int, int], spacing: float, low=(0.0, 0.0, 0.0),
                     seed: int = 0) -> np.ndarray:
    """One point per lattice cell, jittered by up to a quarter spacing from the cell centre (m)."""
    rng = np.random.default_rng(seed)
    cells = np.indices(shape).reshape(3, -1).T + 0.5
    return np.asarray(low) + (cells + rng.uniform(-0.25, 0.25, cells.shape)) * spacing


def edge_uses(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How many faces use each undirected edge, and each directed edge (a → b in a face's turn)."""
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    _, undirected_counts = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    _, directed_counts = np.unique(directed, axis=0, return_counts=True)
    return undirected_counts, directed_counts


def assert_watertight(faces: np.ndarray) -> None:
    """Every edge is shared by exactly two faces that turn it in opposite directions."""
    undirected, directed = edge_uses(faces)
    assert len(faces) > 0
    assert np.all(undirected == 2)
    assert np.all(directed == 1)
