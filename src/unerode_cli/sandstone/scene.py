"""The sandstone scene (002 §3.3): a domain, the ground, a constructive solid geometry of boxes,
spheres and cylinders, the stack of sediment layers, painted regions and value noise on
log-erodibility. A pydantic model validates a scene's mapping (a YAML file, a preset).

Example (lengths in m, erodibilities in 1/y, stresses in Pa, k_t in 1/Pa)::

    domain: {size: [40, 16, 30]}        # x east, y north, z up, from origin (default 0, 0)
    ground: 0                           # altitude of the ground plane and of the domain's bottom
    particles: 50000                    # or cell_size: 0.5 (the MPM grid; 8 particles per cell)
    shape:
      difference:
        - box: {min: [5, 5, 0], max: [35, 11, 20]}
        - sphere: {centre: [20, 8, 0], radius: 6}
    layers:                             # bottom first; the last top may be omitted
      - {top: 8, k_w: 2e-4, interlocking: 1.5e6}
      - {k_w: 5e-5, interlocking: 3e6, k_t: 100, tau_c: 5}
    paint:                              # later regions override earlier ones
      - {shape: {box: {min: [5, 5, 0], max: [8, 11, 20]}}, erodibility: 0}
    noise: {amplitude: 0.5, wavelength: 4, seed: 1}
    wind: {azimuth: 180, speed: 10}      # from the south
    water:                              # fluvial erosion needs a layer with k_t > 0
      precipitation: 0.25               # m/y
      sources: [{position: [20, 8, 20], discharge: 1e5}]   # m, m³/y
    run: {frames: 80, dt: 4000}         # what the landform needs; --frames and --dt override
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from unerode_cli.sandstone.fluvial import PRECIPITATION
from unerode_cli.sandstone.layers import Layer, LayerStack, Rock

Vec3 = tuple[float, float, float]
SHAPE_KINDS = ("box", "sphere", "cylinder", "union", "intersection", "difference")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Box(_Strict):
    """An axis-aligned box: ``min`` and ``max`` corners, or ``centre`` and ``size`` (m)."""

    min: Vec3 | None = None
    max: Vec3 | None = None
    centre: Vec3 | None = None
    size: Vec3 | None = None

    @model_validator(mode="after")
    def _corners(self) -> Box:
        if (self.min is None) != (self.max is None) or (self.centre is None) != (self.size is None) \
                or (self.min is None) == (self.centre is None):
            raise ValueError("a box takes either min and max, or centre and size")
        low, high = self.corners()
        if np.any(high <= low):
            raise ValueError(f"a box must have positive sizes, got {tuple((high - low).tolist())}")
        return self

    def corners(self) -> tuple[np.ndarray, np.ndarray]:
        if self.min is not None:
            return np.asarray(self.min, float), np.asarray(self.max, float)
        centre, half = np.asarray(self.centre, float), 0.5 * np.asarray(self.size, float)
        return centre - half, centre + half

    def contains(self, points: np.ndarray) -> np.ndarray:
        low, high = self.corners()
        return np.all((points >= low) & (points <= high), axis=1)


class Sphere(_Strict):
    """A ball of ``radius`` (m) around ``centre`` (m)."""

    centre: Vec3
    radius: float = Field(gt=0)

    def contains(self, points: np.ndarray) -> np.ndarray:
        return np.sum((points - np.asarray(self.centre)) ** 2, axis=1) <= self.radius**2


class Cylinder(_Strict):
    """A cylinder of ``radius`` and ``height`` (m) along ``axis``, from the centre of its bottom
    face ``base`` (m)."""

    base: Vec3
    radius: float = Field(gt=0)
    height: float = Field(gt=0)
    axis: Literal["x", "y", "z"] = "z"

    def contains(self, points: np.ndarray) -> np.ndarray:
        a = "xyz".index(self.axis)
        offset = points - np.asarray(self.base)
        across = np.delete(offset, a, axis=1)
        along = offset[:, a]
        return (np.sum(across**2, axis=1) <= self.radius**2) & (along >= 0) & (along <= self.height)


class Shape(_Strict):
    """One node of the CSG tree: a mapping with exactly one key, a primitive (``box``, ``sphere``,
    ``cylinder``) or an operation on a list of shapes (``union``, ``intersection``,
    ``difference``: the first shape minus the others)."""

    box: Box | None = None
    sphere: Sphere | None = None
    cylinder: Cylinder | None = None
    union: list[Shape] | None = None
    intersection: list[Shape] | None = None
    difference: list[Shape] | None = None

    @model_validator(mode="before")
    @classmethod
    def _one_kind(cls, data: Any) -> Any:
        if not isinstance(data, dict) or len(data) != 1:
            raise ValueError(f"a shape is a mapping with one key, one of {', '.join(SHAPE_KINDS)}")
        (kind,) = data
        if kind not in SHAPE_KINDS:
            raise ValueError(f"unknown shape '{kind}' (known: {', '.join(SHAPE_KINDS)})")
        operation = kind in ("union", "intersection", "difference")
        if operation and not (isinstance(data[kind], list) and data[kind]):
            raise ValueError(f"'{kind}' takes a non-empty list of shapes")
        return data

    @property
    def kind(self) -> str:
        return next(k for k in SHAPE_KINDS if getattr(self, k) is not None)

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Which of the points ``(M, 3)`` (m) lie inside the shape (boundaries included)."""
        node = getattr(self, self.kind)
        if not isinstance(node, list):
            return node.contains(points)
        inside = node[0].contains(points)
        for child in node[1:]:
            if self.kind == "union":
                inside |= child.contains(points)
            elif self.kind == "intersection":
                inside &= child.contains(points)
            else:
                inside &= ~child.contains(points)
        return inside


class Domain(_Strict):
    """The simulated box: ``size`` (m) along x, y, z from ``origin`` (m, x and y; its z is the
    scene's ground)."""

    size: Vec3
    origin: tuple[float, float] = (0.0, 0.0)

    @field_validator("size")
    @classmethod
    def _positive(cls, size: Vec3) -> Vec3:
        if min(size) <= 0:
            raise ValueError(f"the domain size must be positive along x, y and z, got {size}")
        return size


class LayerSpec(_Strict):
    """A sediment layer (see :class:`~unerode_cli.sandstone.layers.Layer` for units)."""

    top: float | None = None
    k_w: float = Field(Layer.k_w, ge=0)
    k_s: float = Field(Layer.k_s, ge=0)
    interlocking: float = Field(Layer.interlocking, ge=0)
    k_a: float = Field(Layer.k_a, ge=0)
    k_d: float = Field(Layer.k_d, ge=0)
    k_t: float = Field(Layer.k_t, ge=0)
    tau_c: float = Field(Layer.tau_c, ge=0)
    name: str = ""

    def layer(self) -> Layer:
        return Layer(top=math.inf if self.top is None else self.top, k_w=self.k_w, k_s=self.k_s,
                     interlocking=self.interlocking, k_a=self.k_a, k_d=self.k_d, k_t=self.k_t,
                     tau_c=self.tau_c, name=self.name)


class Paint(_Strict):
    """A painted region (002 §3.3, §8.3): the particles inside ``shape`` get an erodibility
    factor (multiplies k_w and k_s; 0 = non-erodible) and/or a vegetation cover in [0, 1]."""

    shape: Shape
    erodibility: float | None = Field(None, ge=0)
    vegetation: float | None = Field(None, ge=0, le=1)


class Noise(_Strict):
    """Value noise on log-erodibility (002 §3.3): the erodibility factor is multiplied by
    exp(``amplitude``·n), n ∈ [−1, 1] smooth over ``wavelength`` (m), ``octaves`` halvings."""

    amplitude: float = Field(ge=0)
    wavelength: float = Field(gt=0)
    seed: int = Field(0, ge=0)
    octaves: int = Field(1, ge=1, le=8)


class RoseWind(_Strict):
    """One prevailing wind of a rose: the ``azimuth`` it comes from (degrees clockwise from
    north) and its ``weight``, its share of the time once the weights are normalised."""

    azimuth: float = Field(ge=0, le=360)
    weight: float = Field(gt=0)


class Wind(_Strict):
    """The storm wind of abrasion (002 Eq. 8): it comes *from* ``azimuth`` (degrees clockwise
    from north; 270 is a west wind), ``elevation`` degrees above the horizon, at ``speed`` (m/s);
    ``cone_angle`` (degrees) and ``rays`` set its shelter model (``sandstone.wind``). A ``rose``
    of prevailing winds, ``[{azimuth: 270, weight: 2}, {azimuth: 90, weight: 1}, …]``, replaces
    ``azimuth``: the wind blows from each for its share of the time. ``model``: ``rays`` (exposure
    by rays cast upwind) or ``flow`` (the local wind of the flow around the rock,
    ``sandstone.wind_flow``)."""

    model: Literal["rays", "flow"] = "rays"
    azimuth: float = 270.0
    elevation: float = Field(0.0, ge=-90, le=90)
    speed: float = Field(10.0, ge=0)
    cone_angle: float = Field(10.0, ge=0, lt=90)
    rays: int = Field(16, ge=1)
    rose: list[RoseWind] = Field(default_factory=list)

    def rose_pairs(self) -> tuple[tuple[float, float], ...]:
        """The rose as (azimuth in degrees, weight) pairs; () without one."""
        return tuple((wind.azimuth, wind.weight) for wind in self.rose)


class WaterSource(_Strict):
    """A point source of water (002 §8.2): it enters the cell of ``position`` (m) with
    ``discharge`` Q (m³/y)."""

    position: Vec3
    discharge: float = Field(ge=0)


class Water(_Strict):
    """The water of fluvial erosion (002 §6): ``precipitation`` p (m/y) on the top of the
    domain and point ``sources``."""

    precipitation: float = Field(PRECIPITATION, ge=0)
    sources: list[WaterSource] = Field(default_factory=list)

    def source_tuples(self) -> tuple[tuple[float, float, float, float], ...]:
        """Each source as (x, y, z, Q) (m, m³/y)."""
        return tuple((*source.position, source.discharge) for source in self.sources)


class RunSettings(_Strict):
    """The ``frames`` and time step ``dt`` (years) a scene's landform needs: the defaults of
    ``--frames`` and ``--dt`` for it."""

    frames: int = Field(ge=1)
    dt: float = Field(gt=0, allow_inf_nan=False)


class Scene(_Strict):
    """A whole scene; see the module docstring for an example."""

    domain: Domain
    ground: float = 0.0
    cell_size: float | None = Field(None, gt=0)
    particles: int | None = Field(None, ge=1)
    shape: Shape
    layers: list[LayerSpec] = Field(default_factory=lambda: [LayerSpec()], min_length=1)
    deposit: LayerSpec = LayerSpec()
    rock: dict[str, float] = Field(default_factory=dict)
    paint: list[Paint] = Field(default_factory=list)
    noise: Noise | None = None
    wind: Wind = Wind()
    water: Water = Water()
    run: RunSettings | None = None

    @model_validator(mode="after")
    def _consistent(self) -> Scene:
        tops = [layer.top for layer in self.layers]
        if any(top is None for top in tops[:-1]):
            raise ValueError("every layer but the last needs a top altitude")
        given = [t for t in tops if t is not None]
        if any(b <= a for a, b in zip(given, given[1:], strict=False)):
            raise ValueError(f"layer tops must increase from the bottom layer up, got {given}")
        unknown = set(self.rock) - set(Rock.__dataclass_fields__)
        if unknown:
            raise ValueError(f"unknown rock parameter '{sorted(unknown)[0]}' "
                             f"(known: {', '.join(Rock.__dataclass_fields__)})")
        if self.cell_size is not None and self.particles is not None:
            raise ValueError("give either cell_size or particles, not both")
        high = self.low + np.asarray(self.domain.size)
        for source in self.water.sources:
            if not np.all((np.asarray(source.position) >= self.low) & (np.asarray(source.position) <= high)):
                raise ValueError(f"the water source at {source.position} m lies outside the domain "
                                 f"{tuple(self.low.tolist())} to {tuple(high.tolist())} m")
        return self

    @property
    def low(self) -> np.ndarray:
        """The domain's low corner (m)."""
        return np.array([*self.domain.origin, self.ground])

    def layer_stack(self) -> LayerStack:
        return LayerStack(tuple(spec.layer() for spec in self.layers), self.deposit.layer())

    def rock_parameters(self) -> Rock:
        return Rock(**self.rock)


def parse_scene(data: Any) -> Scene:
    """Validate a scene mapping; ValueError with one sentence naming where it is wrong."""
    try:
        return Scene.model_validate(data)
    except ValidationError as exc:
        raise ValueError(describe(exc)) from None


def describe(exc: ValidationError) -> str:
    """The first error of a validation as one sentence: ``where: what``."""
    error = exc.errors()[0]
    where = ".".join(str(part) for part in error["loc"] if not str(part).startswith("function-"))
    message = error["msg"].removeprefix("Value error, ")
    return f"{where}: {message}" if where else message


def value_noise(points: np.ndarray, wavelength: float, seed: int, octaves: int = 1) -> np.ndarray:
    """Smooth value noise in [−1, 1] at ``points`` (m): random values on a lattice of spacing
    ``wavelength`` (a counter-based hash of seed and lattice index, so the same point always
    gets the same value), blended with smoothstep weights; ``octaves`` add halved wavelengths
    at halved amplitudes, normalised back to [−1, 1]."""
    total = np.zeros(len(points))
    weight = 0.0
    for octave in range(octaves):
        scale = 0.5**octave
        total += scale * _one_octave(points / (wavelength * scale), seed + 7919 * octave)
        weight += scale
    return total / weight


def _one_octave(u: np.ndarray, seed: int) -> np.ndarray:
    base = np.floor(u)
    t = u - base
    s = t * t * (3.0 - 2.0 * t)
    cell = base.astype(np.int64)
    value = np.zeros(len(u))
    for corner in range(8):
        offset = np.array([(corner >> a) & 1 for a in range(3)])
        w = np.prod(np.where(offset == 1, s, 1.0 - s), axis=1)
        value += w * lattice_value(cell + offset, seed)
    return value


def lattice_value(cells: np.ndarray, seed: int) -> np.ndarray:
    """A value in [−1, 1] per integer lattice point ``(M, 3)``: splitmix64 of the seed and the
    index, so it depends on nothing else (not on the order or chunking of the points)."""
    key = _splitmix(np.full(len(cells), seed % (1 << 64), dtype=np.uint64))
    for a in range(3):
        with np.errstate(over="ignore"):
            key = _splitmix(key ^ cells[:, a].astype(np.uint64) * np.uint64(0xBF58476D1CE4E5B9 + 2 * a))
    return (key >> np.uint64(11)).astype(np.float64) / float(1 << 53) * 2.0 - 1.0


def _splitmix(x: np.ndarray) -> np.ndarray:
    with np.errstate(over="ignore"):
        x = x + np.uint64(0x9E3779B97F4A7C15)
        x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return x ^ (x >> np.uint64(31))
