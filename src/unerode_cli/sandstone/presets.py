"""Preset scenes of 002 §8.1 (Fig. 7, Table 1): ``arch`` and ``hoodoo``.

002 gives their shapes in words and pictures only; the sizes here are this project's choice
(tens of metres, as 002's mid-scale structures), the layer parameters are Table 1's ranges
(I in Pa, k_a and k_d scaled as :mod:`~unerode_cli.sandstone.layers` says) and the particle
counts Table 1's.

- ``arch`` (Fig. 7 row 1): "a rectangular cuboid ... on top of a distinct support condition,
  stacked layers with varied erodibility (darker is stronger) and a lateral wind". A fin 52 m
  long, 8 m thick and 36 m high resting on two supports 10 m long (the lowest 8 m of each end,
  painted ten times less erodible), a 2 m high slit between them under the fin; four layers,
  weakest at the bottom; wind from the south, across the fin. A fin standing on the ground along
  its whole length does not open: its base thins until it carries the fin at the interlocking
  stress, like a pillar; over the slit the fin is a deep beam whose lower part is in tension,
  where interlocking cannot protect it. The domain leaves 2 m around the fin: it stands on a
  ridge, and most of its debris falls off the domain (exported) instead of burying its foot.
- ``hoodoo`` (Fig. 7 row 2): "a vertical cuboid with varied erodibility ..., the upper layer
  strong with low erodibility ..., a lateral wind". A 10 m × 10 m column 30 m high, a 6 m
  caprock a hundred times less erodible on three weak layers; wind from the west; 2 m of domain
  around it, as for the arch.
"""

from __future__ import annotations

from typing import Any

from unerode_cli.sandstone.layers import ABRASION_SCALE, DEFLATION_SCALE
from unerode_cli.sandstone.scene import Scene, parse_scene


def _layer(top: float | None, k_w: float, interlocking: float, k_a: float, k_d: float,
           name: str) -> dict[str, Any]:
    """A layer from Table 1's values (k_a, k_d as printed, I in Pa) and Table 2's k_s."""
    layer = {"k_w": k_w, "k_s": 1e-6, "interlocking": interlocking, "k_a": k_a * ABRASION_SCALE,
             "k_d": k_d * DEFLATION_SCALE, "name": name}
    return layer if top is None else {"top": top, **layer}


ARCH: dict[str, Any] = {
    "domain": {"size": [56.0, 12.0, 40.0]},
    "particles": 1_000_000,
    "shape": {"difference": [{"box": {"min": [2.0, 2.0, 0.0], "max": [54.0, 10.0, 36.0]}},
                             {"box": {"min": [12.0, 0.0, 0.0], "max": [44.0, 12.0, 2.0]}}]},
    "layers": [
        _layer(6.0, 1e-4, 1.5e6, 2.5e-5, 5e-7, "weak base"),
        _layer(14.0, 5e-5, 2.0e6, 1.2e-5, 2.5e-7, "lower"),
        _layer(26.0, 3e-5, 2.5e6, 6e-6, 1.2e-7, "upper"),
        _layer(None, 1e-5, 3.0e6, 2.5e-6, 5e-8, "cap"),
    ],
    "deposit": _layer(None, 1e-4, 1.5e6, 2.5e-5, 5e-7, "deposit"),
    "rock": {"deposit_viability": 0.0},
    "paint": [
        {"shape": {"box": {"min": [2.0, 2.0, 0.0], "max": [12.0, 10.0, 8.0]}}, "erodibility": 0.1},
        {"shape": {"box": {"min": [44.0, 2.0, 0.0], "max": [54.0, 10.0, 8.0]}}, "erodibility": 0.1},
    ],
    "noise": {"amplitude": 0.3, "wavelength": 4.0, "seed": 1},
    "wind": {"azimuth": 180.0, "speed": 10.0},
}

HOODOO: dict[str, Any] = {
    "domain": {"size": [14.0, 14.0, 34.0]},
    "particles": 1_000_000,
    "shape": {"box": {"min": [2.0, 2.0, 0.0], "max": [12.0, 12.0, 30.0]}},
    "layers": [
        _layer(8.0, 1e-4, 3e6, 2e-5, 1e-7, "weak base"),
        _layer(16.0, 8e-5, 4e6, 1.5e-5, 8e-8, "middle"),
        _layer(24.0, 6e-5, 5e6, 1e-5, 6e-8, "upper"),
        _layer(None, 1e-6, 6e6, 2e-6, 1e-8, "caprock"),
    ],
    "deposit": _layer(None, 1e-4, 3e6, 2e-5, 1e-7, "deposit"),
    "rock": {"deposit_viability": 0.0},
    "noise": {"amplitude": 0.3, "wavelength": 3.0, "seed": 2},
    "wind": {"azimuth": 270.0, "speed": 10.0},
}

PRESETS: dict[str, dict[str, Any]] = {"arch": ARCH, "hoodoo": HOODOO}


def preset_scene(name: str) -> Scene:
    """The scene of a preset; ValueError naming the presets for an unknown name."""
    if name not in PRESETS:
        raise ValueError(f"unknown preset '{name}' (known: {', '.join(PRESETS)})")
    return parse_scene(PRESETS[name])
