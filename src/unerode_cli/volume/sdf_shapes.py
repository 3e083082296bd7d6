"""The scenes of implicit terrains (003 §4.3): CSG shapes whose signed distance f (m) is negative
in the ground and positive in the air (003's sign), the ground's surface at f = 0.

Primitives — ``Surface`` (the surface of the heightfield the field is built with), ``Plane``
(the half-space under a plane), ``Box``, ``Sphere``, ``Capsule`` — combined by ``Union`` (f = min)
and ``Difference`` (f = max(a, −b)). ``program`` compiles a scene into a postfix program of
opcodes and parameters (m) that ``sdf_kernels`` evaluates in numba. A heightfield's surface is
f = (z − h(x, y))/n(x, y), h bilinear between the column centres and n = √(1 + |∇h|²): the
normaliser makes f the distance to the surface where it is locally planar.

Frame: x = column·dx (m, east), y = row·dy (m, south), z the elevation (m), with the columns of
a ``volume.voxels.VoxelGeometry``; ``Shape.framed`` moves a scene from map coordinates into it.
Plain Python: importing this module does not load numba.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

Vec3 = tuple[float, float, float]
#: Opcodes of a compiled program and the parameters each primitive takes (row of ``params``).
SURFACE, PLANE, BOX, SPHERE, CAPSULE, GRID, UNION, DIFFERENCE = range(8)
N_PARAMS = 7


def _framed_point(p: Vec3, x0: float, y0: float) -> Vec3:
    return (p[0] - x0, y0 - p[1], p[2])


@dataclass(frozen=True)
class Surface:
    """The ground under the heightfield the field is built with (the DEM): f = (z − h)/n."""

    def framed(self, x0: float, y0: float) -> Surface:
        return self

    def z_range(self) -> tuple[float, float] | None:
        return None

    def program(self) -> list[tuple[int, tuple[float, ...]]]:
        return [(SURFACE, ())]


@dataclass(frozen=True)
class Plane:
    """The half-space below the plane through ``point`` (m) with ``normal`` pointing into the
    air: f = n̂·(p − point)."""

    point: Vec3
    normal: Vec3

    def __post_init__(self) -> None:
        if not math.hypot(*self.normal) > 0:
            raise ValueError("a plane's normal must not be zero")

    def framed(self, x0: float, y0: float) -> Plane:
        return Plane(_framed_point(self.point, x0, y0), (self.normal[0], -self.normal[1], self.normal[2]))

    def z_range(self) -> tuple[float, float] | None:
        return None

    def program(self) -> list[tuple[int, tuple[float, ...]]]:
        n = np.asarray(self.normal, float) / math.hypot(*self.normal)
        return [(PLANE, (*self.point, *n.tolist()))]


@dataclass(frozen=True)
class Box:
    """An axis-aligned box of ``size`` (m, full extents) around ``centre`` (m)."""

    centre: Vec3
    size: Vec3

    def __post_init__(self) -> None:
        if not min(self.size) > 0:
            raise ValueError(f"a box's sizes must be > 0 m, got {self.size}")

    def framed(self, x0: float, y0: float) -> Box:
        return Box(_framed_point(self.centre, x0, y0), self.size)

    def z_range(self) -> tuple[float, float] | None:
        return self.centre[2] - 0.5 * self.size[2], self.centre[2] + 0.5 * self.size[2]

    def program(self) -> list[tuple[int, tuple[float, ...]]]:
        return [(BOX, (*self.centre, *(0.5 * s for s in self.size)))]


@dataclass(frozen=True)
class Sphere:
    """A ball of ``radius`` (m) around ``centre`` (m)."""

    centre: Vec3
    radius: float

    def __post_init__(self) -> None:
        if not self.radius > 0:
            raise ValueError(f"a sphere's radius must be > 0 m, got {self.radius}")

    def framed(self, x0: float, y0: float) -> Sphere:
        return Sphere(_framed_point(self.centre, x0, y0), self.radius)

    def z_range(self) -> tuple[float, float] | None:
        return self.centre[2] - self.radius, self.centre[2] + self.radius

    def program(self) -> list[tuple[int, tuple[float, ...]]]:
        return [(SPHERE, (*self.centre, self.radius))]


@dataclass(frozen=True)
class Capsule:
    """The points within ``radius`` (m) of the segment from ``a`` to ``b`` (m)."""

    a: Vec3
    b: Vec3
    radius: float

    def __post_init__(self) -> None:
        if not self.radius > 0:
            raise ValueError(f"a capsule's radius must be > 0 m, got {self.radius}")

    def framed(self, x0: float, y0: float) -> Capsule:
        return Capsule(_framed_point(self.a, x0, y0), _framed_point(self.b, x0, y0), self.radius)

    def z_range(self) -> tuple[float, float] | None:
        return min(self.a[2], self.b[2]) - self.radius, max(self.a[2], self.b[2]) + self.radius

    def program(self) -> list[tuple[int, tuple[float, ...]]]:
        return [(CAPSULE, (*self.a, *self.b, self.radius))]


@dataclass(frozen=True)
class Union:
    """The union of ``shapes`` (f = min)."""

    shapes: tuple[Shape, ...]

    def framed(self, x0: float, y0: float) -> Union:
        return Union(tuple(s.framed(x0, y0) for s in self.shapes))

    def z_range(self) -> tuple[float, float] | None:
        ranges = [r for s in self.shapes if (r := s.z_range()) is not None]
        return (min(r[0] for r in ranges), max(r[1] for r in ranges)) if ranges else None

    def program(self) -> list[tuple[int, tuple[float, ...]]]:
        return _fold(self.shapes, UNION)


@dataclass(frozen=True)
class Difference:
    """The first of ``shapes`` minus the others (f = max(a, −b))."""

    shapes: tuple[Shape, ...]

    def framed(self, x0: float, y0: float) -> Difference:
        return Difference(tuple(s.framed(x0, y0) for s in self.shapes))

    def z_range(self) -> tuple[float, float] | None:
        return self.shapes[0].z_range()

    def program(self) -> list[tuple[int, tuple[float, ...]]]:
        return _fold(self.shapes, DIFFERENCE)


Shape = Surface | Plane | Box | Sphere | Capsule | Union | Difference


def _fold(shapes: tuple[Shape, ...], operation: int) -> list[tuple[int, tuple[float, ...]]]:
    if not shapes:
        raise ValueError("a union or difference needs at least one shape")
    out = shapes[0].program()
    for shape in shapes[1:]:
        out += [*shape.program(), (operation, ())]
    return out


def uses_surface(shape: Shape) -> bool:
    """Whether the scene contains the heightfield's surface."""
    if isinstance(shape, Union | Difference):
        return any(uses_surface(s) for s in shape.shapes)
    return isinstance(shape, Surface)
