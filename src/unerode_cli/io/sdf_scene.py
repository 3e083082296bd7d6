"""Scenes of implicit terrains (``particle-erode --sdf SCENE.yaml``, 003 §4.3): a YAML tree of
primitives read into ``volume.sdf_shapes`` shapes, validated by pydantic, errors in one sentence
naming the file.

Coordinates are those of the DEM's CRS (x east, y north; a projected CRS in metres) and z the
elevation, all in m; the DEM gives the columns of the terrain and its surface::

    shape:
      difference:                        # the first shape minus the others
        - union:
            - surface: {}                # the ground under the DEM
            - box: {centre: [500100, 5000200, 80], size: [40, 40, 60]}   # or min / max corners
            - plane: {point: [0, 0, 10]} # the ground below z = 10 m (normal: up by default)
        - sphere: {centre: [500300, 5000300, 40], radius: 25}
        - capsule: {a: [500000, 5000100, 20], b: [500400, 5000100, 20], radius: 8}   # a tunnel

Primitives: ``surface`` (no values), ``plane`` (point, normal), ``box`` (centre and size, or
min and max), ``sphere`` (centre, radius), ``capsule`` (a, b, radius); operations ``union`` and
``difference`` on non-empty lists of shapes.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from unerode_cli.errors import InputError
from unerode_cli.io.yaml_files import read_yaml_mapping
from unerode_cli.sandstone.scene import describe
from unerode_cli.volume.sdf_shapes import Box, Capsule, Difference, Plane, Shape, Sphere, Surface, Union

Vec3 = tuple[float, float, float]
PRIMITIVES = ("surface", "plane", "box", "sphere", "capsule")
OPERATIONS = ("union", "difference")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class SurfaceSpec(_Strict):
    """The ground under the DEM."""

    def shape(self) -> Shape:
        return Surface()


class PlaneSpec(_Strict):
    """The half-space below the plane through ``point`` (m) whose ``normal`` points into the air."""

    point: Vec3
    normal: Vec3 = (0.0, 0.0, 1.0)

    def shape(self) -> Shape:
        return Plane(self.point, self.normal)


class BoxSpec(_Strict):
    """An axis-aligned box: ``centre`` and ``size`` (m), or ``min`` and ``max`` corners (m)."""

    centre: Vec3 | None = None
    size: Vec3 | None = None
    min: Vec3 | None = None
    max: Vec3 | None = None

    @model_validator(mode="after")
    def _one_way(self) -> BoxSpec:
        given = tuple(v is not None for v in (self.centre, self.size, self.min, self.max))
        if given not in ((True, True, False, False), (False, False, True, True)):
            raise ValueError("a box takes either centre and size, or min and max")
        return self

    def shape(self) -> Shape:
        if self.centre is not None and self.size is not None:
            return Box(self.centre, self.size)
        assert self.min is not None and self.max is not None
        centre = tuple(0.5 * (a + b) for a, b in zip(self.min, self.max, strict=True))
        return Box(centre, tuple(b - a for a, b in zip(self.min, self.max, strict=True)))


class SphereSpec(_Strict):
    """A ball of ``radius`` (m) around ``centre`` (m)."""

    centre: Vec3
    radius: float = Field(gt=0)

    def shape(self) -> Shape:
        return Sphere(self.centre, self.radius)


class CapsuleSpec(_Strict):
    """The points within ``radius`` (m) of the segment from ``a`` to ``b`` (m)."""

    a: Vec3
    b: Vec3
    radius: float = Field(gt=0)

    def shape(self) -> Shape:
        return Capsule(self.a, self.b, self.radius)


class ShapeSpec(_Strict):
    """One node of the tree: a mapping with exactly one key, a primitive or an operation."""

    surface: SurfaceSpec | None = None
    plane: PlaneSpec | None = None
    box: BoxSpec | None = None
    sphere: SphereSpec | None = None
    capsule: CapsuleSpec | None = None
    union: list[ShapeSpec] | None = None
    difference: list[ShapeSpec] | None = None

    @model_validator(mode="before")
    @classmethod
    def _one_kind(cls, data: Any) -> Any:
        known = ", ".join(PRIMITIVES + OPERATIONS)
        if not isinstance(data, dict) or len(data) != 1:
            raise ValueError(f"a shape is a mapping with one key, one of {known}")
        (kind,) = data
        if kind not in PRIMITIVES + OPERATIONS:
            raise ValueError(f"unknown primitive '{kind}' (known: {known})")
        if kind in OPERATIONS and not (isinstance(data[kind], list) and data[kind]):
            raise ValueError(f"'{kind}' takes a non-empty list of shapes")
        if kind in PRIMITIVES and data[kind] is None:
            return {kind: {}}
        return data

    def shape(self) -> Shape:
        if self.union is not None:
            return Union(tuple(s.shape() for s in self.union))
        if self.difference is not None:
            return Difference(tuple(s.shape() for s in self.difference))
        primitives = (self.surface, self.plane, self.box, self.sphere, self.capsule)
        return next(n for n in primitives if n is not None).shape()


class SceneSpec(_Strict):
    """An implicit terrain's scene: its tree of shapes."""

    shape: ShapeSpec


def read_sdf_scene(path: Path) -> Shape:
    """The shape tree of an SDF scene file (module docstring), in the DEM's CRS.

    Raises:
        InputError: one sentence naming the file: unreadable, not YAML, an unknown key or
            primitive, a missing or bad value.
    """
    document = read_yaml_mapping(path, "the SDF scene file", "a mapping with 'shape'", allow_empty=False)
    try:
        return SceneSpec.model_validate(document).shape.shape()
    except ValidationError as exc:
        raise InputError(f"the SDF scene file {path} is invalid: {describe(exc).rstrip('.')}.") from None
    except ValueError as exc:
        raise InputError(f"the SDF scene file {path} is invalid: {str(exc).rstrip('.')}.") from None
