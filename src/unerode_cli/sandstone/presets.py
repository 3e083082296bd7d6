"""Preset scenes of every example of 002 §8.1–8.2 (Fig. 6, Fig. 7, Table 1): ``arch``,
``hoodoo``, ``arcade``, ``alcove``, ``butte``, ``canyon`` and ``cave``.

002 gives their shapes in words and pictures only; the sizes here are this project's choice
(tens of metres, as 002's mid-scale structures; the butte's hundreds, see below), the layer
parameters are Table 1's ranges (I in Pa, k_a and k_d scaled as
:mod:`~unerode_cli.sandstone.layers` says, k_t in 1/Pa and τ_c in Pa as printed, see
:mod:`~unerode_cli.sandstone.fluvial`) and the particle counts Table 1's (1 M where Table 1 has
no row: canyon and cave). Fluvial erosion runs where a layer has k_t > 0, under the default
precipitation (0.25 m/y) plus the scene's water sources (m³/y). The ablations of 002
Fig. 14–15 are the command line's ``--no-fluvial``, ``--no-abrasion`` and ``--no-deflation`` on
these presets.

- ``arch`` (Fig. 7 row 1): "a rectangular cuboid ... on top of a distinct support condition,
  stacked layers with varied erodibility (darker is stronger) and a lateral wind". A fin 52 m
  long, 8 m thick and 36 m high resting on two supports 10 m long (the lowest 8 m of each end,
  painted ten times less erodible), a 2 m high slit between them under the fin; four layers,
  weakest at the bottom; wind from the south, across the fin. A fin standing on the ground along
  its whole length does not open: its base thins until it carries the fin at the interlocking
  stress, like a pillar; over the slit the fin is a deep beam whose lower part is in tension,
  where interlocking cannot protect it. The domain leaves 2 m around the fin: it stands on a
  ridge, and most of its debris falls off the domain (exported) instead of burying its foot.
  The opening first grows, flat-topped, up to a layer's base; as the fin thins the load of the
  bridge gathers in its legs and haunches, whose compressive stress −tr σ rises until it
  reaches their layers' I (2–2.7 MPa in the lower and upper layers by frame 240 at 30 000
  particles, interlocked), while the middle of the span carries 0–0.4 MPa, its underside in
  tension. The underside then erodes upward between the interlocked haunches: the intrados
  rises towards mid-span, up to the cap. It runs 360 frames of 4000 y by default. The arch is a
  stage: the haunches wear too, and the rise falls after its peak (9.7 m at frame 240, 6.7 m at
  360, at 30 000 particles).
- ``hoodoo`` (Fig. 7 row 2): "a vertical cuboid with varied erodibility ..., the upper layer
  strong with low erodibility ..., a lateral wind". A 10 m × 10 m column 30 m high, a 6 m
  caprock a hundred times less erodible on three weak layers; 2 m of domain around it, as for
  the arch. 002 names "a lateral wind"; a wind from one side only cuts the column on that side
  (a stepped column, no neck), so the preset's wind is a rose from the four quarters, equally
  often: the weak layers narrow from every side under the cap. It runs 400 frames of 1000 y by
  default. A face retreats by about one particle spacing each time its particles' viability is
  used up (002 Eq. 1), so the frames a landform needs grow with the particle count.
- ``arcade`` (Fig. 7 row 3): "the user brushes weaker parts on the weak layer". A wall 40 m long,
  6 m thick and 26 m high on four layers (I from 1 MPa at the bottom to 6 MPa at the top, Table
  1); four balls of radius 2.5 m, 8 m apart, through the wall's weak bottom layer, painted four
  times more erodible. Table 1 has no abrasion for it (k_a = 0): deflation, which spares loaded
  rock (Eq. 12), hollows the weak spots, the load of the wall gathers on the rock between them,
  which interlocks, and pillars separate the cavities. It runs 60 frames of 4000 y by default.
- ``alcove`` (Fig. 7 row 4): "a cuboid ... we disable erosion at the back, left, and right faces,
  and increase the hardness of the top layer ... initialized by a small hole at the foot". A
  block 30 m wide, 14 m deep and 26 m high, its back (north), left and right faces painted
  non-erodible 1.5 m deep, a hard top layer above 18 m, a ball of radius 2 m taken out of the
  foot of its front (south) face, the wind from the south; k_t = 100 /Pa (Table 1) and deposits
  of viability 0.2. It runs 110 frames of 4000 y by default. The recess it makes takes the
  whole erodible width of the face up to the hard top, under a flat roof: a roof faces down, so
  a horizontal wind does not abrade it (Eq. 8), and its compressive stress (0–0.3 MPa) stays
  under the interlocking thresholds (1.5–3 MPa), so nothing shapes it into an arc.
- ``butte`` (Fig. 7 row 5): "a cubical block standing on two larger ones, forming a pyramidal
  structure. We carve a small crevice on the caprock to create an instability, which causes
  fluvial erosion to converge on the right side". Slabs 180 m and 130 m wide, 30 m thick each,
  under an 80 m cube whose top 30 m are a caprock ten times less erodible; a crevice 5 m wide,
  40 m long and 10 m deep in the cap, 15 m from its east (right) edge. Table 1: I = 6 MPa, weak
  wind (k_a 1e-6, k_d 1e-8), τ_c = 1 Pa, k_t from 800 /Pa at the base to 400 /Pa in the cap,
  deposits of viability 0.1. Rain on the top runs to the crevice and over the cap's edges, falls
  onto the slabs and over their edges, which retreat while the caprock stays. The butte has the
  size of Monument Valley's (140 m high): the shear stress grows with the rain a lip gathers
  (τ ∝ Q^0.6, Q ∝ the catchment's area), and a butte tens of metres wide gathers too little
  under 0.25 m/y for Table 1's τ_c (τ < 0.5 Pa at its edges: water does not erode it at all).
- ``canyon`` (Fig. 6 right): "an initial water path on a rock block capped with a gentle slope
  upon a hard layer of rock and ... a high discharge at the water source". A block 26 m × 40 m
  whose top falls gently from 16 m at the north to 12 m at the south (the top of a horizontal
  cylinder of radius 600 m), a path 3 m wide and 1.5 m deep along its middle from 3 m inside
  the north face to the south face (where the previews look from), soft layers (k_t = 400 /Pa)
  over a hard layer below 6 m (k_t = 0.01 /Pa, erodibility a tenth), τ_c = 5 Pa so that the
  rain alone does not erode the top, and a source of 10⁶ m³/y pouring onto the path's head. A
  weak wind from the west.
- ``cave`` (Fig. 6 left): "the initial water course inside a sandstone block with layers of
  rocks with different erodibility, ... a strong water discharge at the river's source ... wind
  deflation with a small coefficient". A block 16 m × 36 m × 16 m; a tunnel of radius 2 m
  (a water course must be wider than the water grid's cells to carry water) from 6 m inside the
  north end to the south face (where the previews look from), at 6 m in a weak layer, in a
  course of rock 3 m around it painted three times more erodible; a source of 10⁶ m³/y at the
  tunnel's closed end; harder layers above and below; deflation and abrasion small (k_d, k_a at
  Table 1's lowest), the wind from the south.
"""

from __future__ import annotations

from typing import Any

from unerode_cli.sandstone.layers import ABRASION_SCALE, DEFLATION_SCALE, Layer
from unerode_cli.sandstone.scene import Scene, parse_scene


def _layer(top: float | None, k_w: float, interlocking: float, k_a: float, k_d: float,
           name: str, k_t: float = Layer.k_t, tau_c: float = Layer.tau_c) -> dict[str, Any]:
    """A layer from Table 1's values (k_a, k_d as printed, I in Pa, k_t in 1/Pa, τ_c in Pa) and
    Table 2's k_s."""
    layer = {"k_w": k_w, "k_s": 1e-6, "interlocking": interlocking, "k_a": k_a * ABRASION_SCALE,
             "k_d": k_d * DEFLATION_SCALE, "k_t": k_t, "tau_c": tau_c, "name": name}
    return layer if top is None else {"top": top, **layer}


def _box(low: list[float], high: list[float]) -> dict[str, Any]:
    return {"box": {"min": low, "max": high}}


ARCH: dict[str, Any] = {
    "domain": {"size": [56.0, 12.0, 40.0]},
    "particles": 1_000_000,
    "shape": {"difference": [_box([2.0, 2.0, 0.0], [54.0, 10.0, 36.0]),
                             _box([12.0, 0.0, 0.0], [44.0, 12.0, 2.0])]},
    "layers": [
        _layer(6.0, 1e-4, 1.5e6, 2.5e-5, 5e-7, "weak base"),
        _layer(14.0, 5e-5, 2.0e6, 1.2e-5, 2.5e-7, "lower"),
        _layer(26.0, 3e-5, 2.5e6, 6e-6, 1.2e-7, "upper"),
        _layer(None, 1e-5, 3.0e6, 2.5e-6, 5e-8, "cap"),
    ],
    "deposit": _layer(None, 1e-4, 1.5e6, 2.5e-5, 5e-7, "deposit"),
    "rock": {"deposit_viability": 0.0},
    "paint": [
        {"shape": _box([2.0, 2.0, 0.0], [12.0, 10.0, 8.0]), "erodibility": 0.1},
        {"shape": _box([44.0, 2.0, 0.0], [54.0, 10.0, 8.0]), "erodibility": 0.1},
    ],
    "noise": {"amplitude": 0.3, "wavelength": 4.0, "seed": 1},
    "wind": {"azimuth": 180.0, "speed": 10.0},
    # the intrados's rise: 1.1 m at frame 120, 9.7 m at 240, 6.7 m at 360 (30 000 particles)
    "run": {"frames": 360, "dt": 4000.0},
}

HOODOO: dict[str, Any] = {
    "domain": {"size": [14.0, 14.0, 34.0]},
    "particles": 1_000_000,
    "shape": _box([2.0, 2.0, 0.0], [12.0, 12.0, 30.0]),
    "layers": [
        _layer(8.0, 1e-4, 3e6, 2e-5, 1e-7, "weak base"),
        _layer(16.0, 8e-5, 4e6, 1.5e-5, 8e-8, "middle"),
        _layer(24.0, 6e-5, 5e6, 1e-5, 6e-8, "upper"),
        _layer(None, 1e-6, 6e6, 2e-6, 1e-8, "caprock"),
    ],
    "deposit": _layer(None, 1e-4, 3e6, 2e-5, 1e-7, "deposit"),
    "rock": {"deposit_viability": 0.0},
    "noise": {"amplitude": 0.3, "wavelength": 3.0, "seed": 2},
    # winds from the four quarters, equally often: a free-standing column is cut from every side
    "wind": {"speed": 10.0, "rose": [{"azimuth": a, "weight": 1.0} for a in (0.0, 90.0, 180.0, 270.0)]},
    # the neck reaches 0.6 × the cap after ~260 frames at 60 000 particles, ~310 at 150 000
    "run": {"frames": 400, "dt": 1000.0},
}

ARCADE: dict[str, Any] = {
    "domain": {"size": [48.0, 12.0, 30.0]},
    "particles": 2_500_000,
    "shape": _box([4.0, 3.0, 0.0], [44.0, 9.0, 26.0]),
    "layers": [
        _layer(8.0, 1e-4, 1e6, 0.0, 8e-7, "weak base"),
        _layer(14.0, 6e-5, 2e6, 0.0, 6e-7, "lower"),
        _layer(20.0, 4e-5, 4e6, 0.0, 4e-7, "upper"),
        _layer(None, 2e-5, 6e6, 0.0, 2e-7, "cap"),
    ],
    "deposit": _layer(None, 1e-4, 1e6, 0.0, 8e-7, "deposit"),
    "rock": {"deposit_viability": 0.0},
    "paint": [{"shape": {"sphere": {"centre": [x, 6.0, 4.5], "radius": 2.5}}, "erodibility": 4.0}
              for x in (12.0, 20.0, 28.0, 36.0)],
    "noise": {"amplitude": 0.2, "wavelength": 3.0, "seed": 3},
    "wind": {"azimuth": 180.0, "speed": 10.0},
    "run": {"frames": 60, "dt": 4000.0},
}

ALCOVE: dict[str, Any] = {
    "domain": {"size": [34.0, 20.0, 30.0]},
    "particles": 1_500_000,
    "shape": {"difference": [_box([2.0, 4.0, 0.0], [32.0, 18.0, 26.0]),
                             {"sphere": {"centre": [17.0, 4.0, 1.0], "radius": 2.0}}]},
    "layers": [
        _layer(8.0, 1e-4, 1.5e6, 4e-5, 4e-7, "weak foot", k_t=100.0),
        _layer(18.0, 5e-5, 2.0e6, 1e-5, 1e-7, "middle", k_t=100.0),
        _layer(None, 1e-5, 3.0e6, 2e-6, 2e-8, "hard top", k_t=100.0),
    ],
    "deposit": _layer(None, 1e-4, 1.5e6, 4e-5, 4e-7, "deposit", k_t=100.0),
    "rock": {"deposit_viability": 0.2},
    "paint": [{"shape": _box(low, high), "erodibility": 0.0} for low, high in (
        ([2.0, 16.5, 0.0], [32.0, 18.0, 26.0]),   # back
        ([2.0, 4.0, 0.0], [3.5, 18.0, 26.0]),     # left
        ([30.5, 4.0, 0.0], [32.0, 18.0, 26.0]),   # right
    )],
    "noise": {"amplitude": 0.3, "wavelength": 3.0, "seed": 4},
    "wind": {"azimuth": 180.0, "speed": 10.0},
    "run": {"frames": 110, "dt": 4000.0},
}

BUTTE: dict[str, Any] = {
    "domain": {"size": [200.0, 200.0, 160.0]},
    "particles": 1_500_000,
    "shape": {"difference": [
        {"union": [_box([10.0, 10.0, 0.0], [190.0, 190.0, 30.0]),
                   _box([35.0, 35.0, 30.0], [165.0, 165.0, 60.0]),
                   _box([60.0, 60.0, 60.0], [140.0, 140.0, 140.0])]},
        _box([120.0, 80.0, 130.0], [125.0, 120.0, 140.0]),
    ]},
    "layers": [
        _layer(30.0, 1e-4, 6e6, 1e-6, 1e-8, "lower slab", k_t=800.0, tau_c=1.0),
        _layer(60.0, 1e-4, 6e6, 1e-6, 1e-8, "upper slab", k_t=700.0, tau_c=1.0),
        _layer(110.0, 8e-5, 6e6, 1e-6, 1e-8, "cube", k_t=600.0, tau_c=1.0),
        _layer(None, 1e-5, 6e6, 1e-6, 1e-8, "caprock", k_t=400.0, tau_c=1.0),
    ],
    "deposit": _layer(None, 1e-4, 6e6, 1e-6, 1e-8, "deposit", k_t=800.0, tau_c=1.0),
    "rock": {"deposit_viability": 0.1},
    "noise": {"amplitude": 0.3, "wavelength": 20.0, "seed": 5},
    "wind": {"azimuth": 270.0, "speed": 10.0},
}

#: The canyon's gentle top: a horizontal cylinder (axis x) of this radius (m) whose crest lies
#: north of the domain, so the top falls from 16 m at y = 42 m to about 12 m at y = 2 m.
CANYON_RADIUS = 600.0
CANYON_CREST_Y = 84.0
CANYON_CREST_Z = 16.0 - (CANYON_RADIUS**2 - (CANYON_CREST_Y - 42.0) ** 2) ** 0.5
#: The canyon's initial water path: the band of x (m), its depth (m) under the top, and the y (m)
#: of its head, where the source pours from about 2 m above the top.
CANYON_PATH = (13.5, 16.5)
CANYON_PATH_DEPTH = 1.5
CANYON_PATH_HEAD = 39.0


def _canyon_top(radius: float) -> dict[str, Any]:
    return {"cylinder": {"base": [0.0, CANYON_CREST_Y, CANYON_CREST_Z], "radius": radius, "height": 30.0,
                         "axis": "x"}}


CANYON: dict[str, Any] = {
    "domain": {"size": [30.0, 44.0, 20.0]},
    "particles": 1_000_000,
    "shape": {"difference": [
        {"intersection": [_box([2.0, 2.0, 0.0], [28.0, 42.0, 18.0]), _canyon_top(CANYON_RADIUS)]},
        {"intersection": [_box([CANYON_PATH[0], 0.0, 0.0], [CANYON_PATH[1], CANYON_PATH_HEAD, 20.0]),
                          {"difference": [_canyon_top(CANYON_RADIUS),
                                          _canyon_top(CANYON_RADIUS - CANYON_PATH_DEPTH)]}]},
    ]},
    "layers": [
        _layer(6.0, 1e-5, 3e6, 2e-6, 2e-8, "hard", k_t=0.01),
        _layer(11.0, 1e-4, 1.5e6, 1e-5, 1e-7, "soft", k_t=400.0),
        _layer(None, 6e-5, 2e6, 6e-6, 6e-8, "top", k_t=400.0),
    ],
    "deposit": _layer(None, 1e-4, 1.5e6, 1e-5, 1e-7, "deposit", k_t=400.0),
    "rock": {"deposit_viability": 0.0},
    "noise": {"amplitude": 0.3, "wavelength": 3.0, "seed": 6},
    "wind": {"azimuth": 270.0, "speed": 5.0},
    "water": {"sources": [{"position": [0.5 * sum(CANYON_PATH), CANYON_PATH_HEAD - 1.0, 18.0],
                           "discharge": 1e6}]},
}

#: The cave's tunnel, along y: its axis's x and z (m), radius (m), the y (m) of its closed
#: (north) end and of the source.
CAVE_AXIS = (8.0, 6.0)
CAVE_RADIUS = 2.0
CAVE_END = 32.0
CAVE_SOURCE_Y = 31.0

CAVE: dict[str, Any] = {
    "domain": {"size": [16.0, 40.0, 18.0]},
    "particles": 1_000_000,
    "shape": {"difference": [
        _box([0.0, 2.0, 0.0], [16.0, 38.0, 16.0]),
        {"cylinder": {"base": [CAVE_AXIS[0], 0.0, CAVE_AXIS[1]], "radius": CAVE_RADIUS, "height": CAVE_END,
                      "axis": "y"}},
    ]},
    "layers": [
        _layer(1.0, 2e-5, 3e6, 2e-6, 2e-8, "hard floor", k_t=0.01),
        _layer(10.0, 1e-4, 1.5e6, 2e-6, 1e-7, "weak", k_t=400.0),
        _layer(None, 4e-5, 2e6, 2e-6, 2e-8, "roof", k_t=100.0),
    ],
    "deposit": _layer(None, 1e-4, 1.5e6, 2e-6, 1e-7, "deposit", k_t=400.0),
    "rock": {"deposit_viability": 0.0},
    "paint": [{"shape": {"intersection": [
        {"cylinder": {"base": [CAVE_AXIS[0], 1.0, CAVE_AXIS[1]], "radius": CAVE_RADIUS + 3.0,
                      "height": CAVE_END, "axis": "y"}},
        _box([0.0, 0.0, 1.0], [16.0, 40.0, 10.0])]}, "erodibility": 3.0}],
    "noise": {"amplitude": 0.3, "wavelength": 3.0, "seed": 7},
    "wind": {"azimuth": 180.0, "speed": 5.0},
    "water": {"sources": [{"position": [CAVE_AXIS[0], CAVE_SOURCE_Y, CAVE_AXIS[1]], "discharge": 1e6}]},
}

PRESETS: dict[str, dict[str, Any]] = {"arch": ARCH, "hoodoo": HOODOO, "arcade": ARCADE, "alcove": ALCOVE,
                                      "butte": BUTTE, "canyon": CANYON, "cave": CAVE}


def preset_scene(name: str) -> Scene:
    """The scene of a preset; ValueError naming the presets for an unknown name."""
    if name not in PRESETS:
        raise ValueError(f"unknown preset '{name}' (known: {', '.join(PRESETS)})")
    return parse_scene(PRESETS[name])
