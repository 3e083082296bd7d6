"""Particles as a field on a grid of any node spacing, whose level ½ is the rock's surface.

Each particle stands for ``particle_volume`` m³ of rock, the cell of a sampling lattice of
spacing s (m; by default particle_volume^(1/3)). The grid's node spacing, the *cell* c (m), is
free (s by default, s/4 to 4 s sensible): the field is defined in metres relative to s, and the
cell only samples it, so a finer cell draws the same rock more finely.

**Blurred volume fraction D.** Each particle's volume goes to its 8 nearest nodes by
cloud-in-cell (trilinear) weights, giving ρ (the volume fraction, ≈ 1 inside), and ρ is blurred
by a Gaussian of standard deviation σ = ``sigma``·s (m), i.e. σ/c nodes, along each axis. D is
≈ 1 inside, 0 far outside and ½ on a flat face, where the level-½ surface
(:func:`~unerode_cli.volume.mesh.surface_mesh`) goes. Convex shapes lose a rim of order
(σ² + c²/6)/R (R the radius of curvature, c²/6 the variance cloud-in-cell adds): a ball of
radius 20 s loses about 1 % of its volume at c ≤ s, 2 % at c = 2 s, 5 % at c = 4 s. 002 (§3,
Alg. 1) meshes its particles by screened Poisson reconstruction instead; a density and marching
cubes need no normals and give a closed surface whatever the particles.

**Thin features.** The blur removes what is thinner than about 1.35 σ: across a sheet one
particle thick D peaks near 0.36, so a sheet that carries load (an arch's fin) would vanish and
what it holds would float. The *presence* P keeps such features. It is the larger of two
readings of where the particles' rock is: ρ convolved along each axis with the tent of
half-width s (the volume fraction seen through the particles' lattice cells: ≈ 1 inside any
lattice, and across a sheet one particle thick a tent that is ½ at s/2 from it), and 1 − d/w, d
the distance (largest along an axis) to the nearest particle, ½ on the union of the cubes of
side w = s around the particles (which keeps a rod's square section, where the tents' product
rounds it). On coarse cells w is at least ``COARSE`` cells, so that whatever its offset to the
nodes a particle's cube holds a node along each axis: a feature thinner than a cell comes out
about a cell thick. P is closed (a maximum then a minimum filter over a cube of side
``CLOSING``·s), which fills the dips between jittered particles and keeps any profile with a
single peak. With particles jittered by up to ¼ s, a sheet one particle thick comes out 1.2 to
1.35 s thick at c ≤ s/2, 1.5 to 1.65 s at c = s and 2.7 to 3 s at c = 2 s; a rod 1 to 1.2 s at
c ≤ s/2 and 0.9 to 1.45 s at c = s.

P alone would bring the lattice's steps back onto every curved surface, which the blur hides,
so P counts only in thin features. A thin place is a node of P ≥ ½ whose run of nodes of
P ≥ ``OCCUPIED`` along some axis is no longer than across a feature ``THIN`` spacings thick:
rock on neither side, as in a sheet or a rod, while a step of a curved surface or an edge has
rock on one side along every axis. Connected thin places make a feature, kept when at least
``MIN_FEATURE`` of its particles lie farther than ``FAR`` spacings from the thick rock (the
other nodes of P ≥ ½); a row of particles lying on a face (which the blur keeps as a bump) or
a few loose grains are left to the blur. Within one node of a kept feature the nodes where
D < ½ take P; everywhere else the field is D. Thick rock keeps its blurred surface (a ball's
or a box's field is D's, node for node), and a sheet stays joined to what carries it: D ≥ ½
(the fillet at the joint) meets P ≥ ½ (the sheet).

The grid extends beyond the particles by the blur's reach and ``MARGIN`` nodes (or the
presence's reach and a node) on every side, where the field is zero, so every surface is
closed. With a ``ground`` altitude (m), the rock stands on the ground plane: the particles near
it are mirrored below it first (so the field does not fade towards the ground), the nodes below
the ground are emptied, and a node layer lies on the ground; the mesh then closes along the
ground plane (see :func:`~unerode_cli.volume.mesh.surface_mesh`). The memory a field needs is
known before anything is allocated (:func:`density_bytes`); a field above ``max_bytes`` is
refused.

Node (i, j, k) of a grid lies at ``origin + h·(i, j, k)`` (m); arrays have shape (nx, ny, nz).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from scipy import ndimage

#: Standard deviation of the blur, in particle spacings, and where it is cut (in standard deviations).
SIGMA = 1.0
TRUNCATE = 3.0
#: Empty nodes kept beyond the reach of the blur on every side.
MARGIN = 2
#: Material index of a node without rock.
NO_MATERIAL = -1
#: Thickest thin feature (particle spacings: one or two particles and their jitter); the run
#: of nodes of presence ≥ ``OCCUPIED`` across it, (``THIN`` − 1)·s + 1.5·w, is the longest thin
#: run (w the side of the particles' cubes).
THIN = 2.5
OCCUPIED = 0.25
#: A thin feature holds at least ``MIN_FEATURE`` particles farther than ``FAR`` particle
#: spacings from thick rock.
MIN_FEATURE = 4
FAR = 1.0
#: Side of the presence's closing (particle spacings), and the least side of a particle's cube
#: in the presence (cells).
CLOSING = 1.5
COARSE = 1.25
#: Peak bytes per grid node while the field is made (float32 field, presence, blurred density of
#: one material and largest so far; int16 materials; the cloud-in-cell in float64; bool masks;
#: int32 labels of the thin places), and per particle (copies, node coordinates and the
#: cloud-in-cell's indices and weights), as measured with tracemalloc.
BYTES_PER_NODE = 36
BYTES_PER_PARTICLE = 400
#: Largest field (bytes) made by default.
MAX_BYTES = 4 << 30


@dataclass(frozen=True)
class Density:
    """The field ``values`` (float32, dimensionless) whose level ½ is the rock's surface, at the
    nodes ``origin + h·(i, j, k)`` (m): the blurred volume fraction, or the presence in thin
    features (see the module's text); the dominant ``materials`` (int16, :data:`NO_MATERIAL`
    where there is no rock) and the ``ground`` altitude (m) the rock stands on, or None."""

    values: np.ndarray
    materials: np.ndarray
    origin: tuple[float, float, float]
    h: float
    ground: float | None = None


def particle_density(positions: np.ndarray, materials: np.ndarray, particle_volume: float,
                     cell: float | None = None, sigma: float = SIGMA, ground: float | None = None,
                     max_bytes: float = MAX_BYTES, spacing: float | None = None) -> Density:
    """The field of particles at ``positions`` (N, 3) (m), each ``particle_volume`` m³ of the
    material ``materials`` (N,) (integers ≥ 0, e.g. layer indices), sampled at the node spacing
    ``cell`` (m; None: the particle spacing), blurred by ``sigma`` particle spacings;
    ``ground``: the altitude (m) of the plane the rock stands on; ``spacing``: the particle
    spacing s (m; None: particle_volume^(1/3)). The dominant material of a node is the one of
    largest blurred density there. Raises ValueError when the field would need more than
    ``max_bytes`` bytes (:func:`density_bytes`)."""
    positions = np.asarray(positions, dtype=np.float64)
    materials = np.asarray(materials)
    s, h, blur, reach = _scales(particle_volume, cell, sigma, spacing)
    real = len(positions) if ground is None else int(np.count_nonzero(positions[:, 2] >= ground))
    if ground is not None:
        positions, materials = _mirrored(positions, materials, ground, reach * h)
    if len(positions) == 0:
        raise ValueError("there are no particles (above the ground) to make a density of")
    if materials.min() < 0:
        raise ValueError("material indices must be non-negative")
    origin, shape = _grid(positions.min(axis=0), positions.max(axis=0), h, reach, ground)
    need = BYTES_PER_NODE * math.prod(shape) + BYTES_PER_PARTICLE * len(positions)
    if need > max_bytes:
        raise ValueError(f"a mesh cell of {h:g} m needs a grid of {' × '.join(map(str, shape))} nodes, "
                         f"about {need / 2**30:.2f} GiB, more than the {max_bytes / 2**30:.2f} GiB allowed: "
                         "choose a coarser cell")
    occupancy, total, dominant = _blurred(positions, materials, origin, h, shape, particle_volume / h**3,
                                          blur)
    nodes = (positions - origin) / h  # the particles in node coordinates
    presence = _presence(occupancy, nodes, s / h)
    del occupancy
    _keep_thin_features(total, presence, s / h, nodes[:real])
    del presence, nodes
    if ground is None:
        return Density(total, dominant, tuple(map(float, origin)), h)  # type: ignore[arg-type]
    below = int(round((ground - origin[2]) / h))  # the node layer on the ground
    total = total[:, :, below - 1:]
    total[:, :, 0] = 0.0
    origin[2] = ground - h
    return Density(total, dominant[:, :, below - 1:], tuple(map(float, origin)), h,  # type: ignore[arg-type]
                   float(ground))


def density_bytes(low: np.ndarray, high: np.ndarray, particles: int, particle_volume: float,
                  cell: float | None = None, sigma: float = SIGMA, ground: float | None = None,
                  spacing: float | None = None) -> int:
    """The peak bytes :func:`particle_density` needs for ``particles`` particles within the box
    ``low``–``high`` (m, (3,) each), with the same other arguments: ``BYTES_PER_NODE`` per node of
    its grid and ``BYTES_PER_PARTICLE`` per particle and mirror image, the images counted as the
    share of the box's height within their reach of the ground."""
    _, h, _, reach = _scales(particle_volume, cell, sigma, spacing)
    low, high = np.array(low, dtype=np.float64), np.array(high, dtype=np.float64)
    images = 0
    if ground is not None:  # the mirror images of the particles within reach of the ground
        low[2] = max(low[2], ground)
        images = math.ceil(particles * min(1.0, reach * h / max(high[2] - low[2], h)))
        low[2] = min(low[2], 2.0 * ground - min(high[2], ground + reach * h))
    _, shape = _grid(low, high, h, reach, ground)
    return BYTES_PER_NODE * math.prod(shape) + BYTES_PER_PARTICLE * (particles + images)


def _scales(particle_volume: float, cell: float | None, sigma: float,
            spacing: float | None) -> tuple[float, float, float, int]:
    """The particle spacing s (m), the node spacing h (m), the blur (nodes) and the nodes kept
    beyond the particles: the reach of the blur and ``MARGIN``, or of the closed presence (zero
    from :func:`_cube` + :func:`_closing` − 1 nodes away) and a node."""
    s = (float(particle_volume) ** (1.0 / 3.0) if particle_volume > 0.0 else 0.0) if spacing is None \
        else float(spacing)
    h = s if cell is None else float(cell)
    if not (h > 0.0 and s > 0.0 and particle_volume > 0.0 and sigma > 0.0):
        raise ValueError("the node spacing, particle spacing, particle volume and blur must be positive")
    blur = sigma * s / h
    return s, h, blur, max(math.ceil(TRUNCATE * blur) + MARGIN, math.ceil(_cube(s / h) + _closing(s / h)))


def _grid(low: np.ndarray, high: np.ndarray, h: float, reach: int,
          ground: float | None) -> tuple[np.ndarray, tuple[int, int, int]]:
    """The origin (m) and shape of a grid of spacing ``h`` covering the box ``low``–``high`` (m)
    and ``reach`` nodes beyond; with a ``ground``, a node layer on it and at least one below."""
    origin = np.array(low, dtype=np.float64) - reach * h
    if ground is not None:
        origin[2] = ground - h * math.ceil((ground - min(origin[2], ground - h)) / h)
    shape = tuple(int(n) for n in np.floor((np.asarray(high) + reach * h - origin) / h) + 2)
    return origin, shape  # type: ignore[return-value]


def _blurred(positions: np.ndarray, materials: np.ndarray, origin: np.ndarray, h: float,
             shape: tuple[int, int, int], scale: float,
             blur: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The cloud-in-cell volume fraction ρ of all particles, its blur D by ``blur`` nodes (both
    float32) and the material of largest blurred density at each node (int16)."""
    occupancy = np.zeros(shape, dtype=np.float32)
    total = np.zeros(shape, dtype=np.float32)
    best = np.zeros(shape, dtype=np.float32)
    dominant = np.full(shape, NO_MATERIAL, dtype=np.int16)
    for material in np.unique(materials):
        mine = _cloud_in_cell(positions[materials == material], origin, h, shape, scale)
        occupancy += mine
        field = ndimage.gaussian_filter(mine, blur, mode="constant", truncate=TRUNCATE)
        del mine
        total += field
        larger = field > best
        best[larger] = field[larger]
        dominant[larger] = material
    return occupancy, total, dominant


def _presence(occupancy: np.ndarray, particles: np.ndarray, ratio: float) -> np.ndarray:
    """The presence P (float32, reusing ``occupancy``, the volume fraction ρ): the larger of ρ
    convolved along each axis with the tent of half-width ``ratio`` nodes (the particle spacing;
    weights summing to 1, none when the tent fits within a node) and, from the ``particles``
    (N, 3) (node coordinates), 1 − d/w, d the distance (largest along an axis) to the nearest
    particle and w the side of its cube (:func:`_cube`); closed (a maximum then a minimum
    filter) over a cube of :func:`_closing` nodes, which fills the dips between jittered
    particles and keeps any profile with a single peak."""
    work = np.empty_like(occupancy)
    if ratio > 1.0:
        reach = math.ceil(ratio) - 1
        weights = 1.0 - np.abs(np.arange(-reach, reach + 1)) / ratio
        weights /= weights.sum()
        ndimage.correlate1d(occupancy, weights, axis=0, output=work, mode="constant")
        ndimage.correlate1d(work, weights, axis=1, output=occupancy, mode="constant")
        ndimage.correlate1d(occupancy, weights, axis=2, output=work, mode="constant")
        occupancy, work = work, occupancy
    _cells_presence(occupancy, particles, _cube(ratio))
    size = _closing(ratio)
    ndimage.maximum_filter(occupancy, size, output=work, mode="constant")
    ndimage.minimum_filter(work, size, output=occupancy, mode="constant",
                           origin=-1 if size % 2 == 0 else 0)
    return occupancy


@numba.njit(cache=True)
def _cells_presence(presence, particles, width):
    """Raise ``presence`` (nx, ny, nz) to 1 − d/``width`` at each node within ``width`` nodes of
    a particle of ``particles`` (N, 3) (node coordinates), d its distance (nodes, largest along
    an axis) to the nearest: ½ on the union of the cubes of side ``width`` around the particles.
    The maximum does not depend on the particles' order."""
    nx, ny, nz = presence.shape
    for p in range(particles.shape[0]):
        x, y, z = particles[p, 0], particles[p, 1], particles[p, 2]
        for i in range(max(0, math.ceil(x - width)), min(nx, math.floor(x + width) + 1)):
            for j in range(max(0, math.ceil(y - width)), min(ny, math.floor(y + width) + 1)):
                for k in range(max(0, math.ceil(z - width)), min(nz, math.floor(z + width) + 1)):
                    d = max(abs(i - x), abs(j - y), abs(k - z))
                    value = 1.0 - d / width
                    if value > presence[i, j, k]:
                        presence[i, j, k] = value


def _cube(ratio: float) -> float:
    """The side (nodes) of the cube a particle marks in the presence: its lattice cell (``ratio``
    nodes), or ``COARSE`` nodes when cells are coarse, so that whatever its offset to the nodes
    a particle's cube holds a node along each axis."""
    return max(ratio, COARSE)


def _closing(ratio: float) -> int:
    """The side (nodes, at least 2) of the presence's closing: ``CLOSING`` particle spacings of
    ``ratio`` nodes, and one node."""
    return max(2, round(CLOSING * ratio) + 1)


def _keep_thin_features(field: np.ndarray, presence: np.ndarray, ratio: float,
                        particles: np.ndarray) -> None:
    """Set ``field`` (the blurred density D, float32) to the ``presence`` P at the nodes where
    D < ½ within one node of the thin places that hold at least ``MIN_FEATURE`` of the
    ``particles`` (M, 3) (node coordinates) farther than ``FAR`` particle spacings from thick
    rock (see the module's text); ``ratio``: the particle spacing in nodes."""
    labels, count, far = _thin_places(presence, ratio)
    if count == 0:
        return
    nearest = np.rint(particles).astype(np.int64)
    hosts = labels[nearest[:, 0], nearest[:, 1], nearest[:, 2]]
    hosts = hosts[far[nearest[:, 0], nearest[:, 1], nearest[:, 2]]]
    del far, nearest
    kept = np.bincount(hosts, minlength=count + 1) >= MIN_FEATURE
    kept[0] = False
    if kept.any():
        zone = ndimage.binary_dilation(kept[labels]) & (field < 0.5)
        field[zone] = presence[zone]


def _thin_places(presence: np.ndarray, ratio: float) -> tuple[np.ndarray, int, np.ndarray]:
    """The connected thin places (labels int32, 0 elsewhere, and their count): nodes of
    ``presence`` ≥ ½ whose run of nodes of presence ≥ ``OCCUPIED`` along some axis is at most
    that across a feature ``THIN`` particle spacings (``ratio`` nodes each) thick; and whether
    each node is farther than ``FAR`` spacings (along each axis) from the other nodes of
    presence ≥ ½, the thick rock."""
    occupied = presence >= OCCUPIED
    run = max(1, math.ceil((THIN - 1.0) * ratio + 1.5 * _cube(ratio) - 1e-9))  # longest thin run, nodes
    thick = presence >= 0.5
    for axis in range(3):  # an opening by a segment of run + 1 nodes keeps the longer runs
        core = ndimage.minimum_filter1d(occupied, run + 1, axis=axis, mode="constant", cval=0)
        thick &= ndimage.maximum_filter1d(core, run + 1, axis=axis, mode="constant", cval=0,
                                          origin=-1 if run % 2 else 0)
    del core, occupied
    labels, count = ndimage.label((presence >= 0.5) & ~thick)
    near = 2 * math.ceil(FAR * ratio - 1e-9) + 1
    for axis in range(3):
        ndimage.maximum_filter1d(thick, near, axis=axis, output=thick, mode="constant", cval=0)
    return labels, count, ~thick


def _mirrored(positions: np.ndarray, materials: np.ndarray, ground: float,
              reach: float) -> tuple[np.ndarray, np.ndarray]:
    """The particles and, appended, the mirror images below ``ground`` of those within
    ``reach`` (m) above it; particles below the ground are dropped."""
    above = positions[:, 2] >= ground
    positions, materials = positions[above], materials[above]
    near = positions[:, 2] < ground + reach
    images = positions[near].copy()
    images[:, 2] = 2.0 * ground - images[:, 2]
    return np.concatenate([positions, images]), np.concatenate([materials, materials[near]])


def _cloud_in_cell(positions: np.ndarray, origin: np.ndarray, h: float, shape: tuple[int, ...],
                   scale: float) -> np.ndarray:
    """``scale`` per particle spread over its 8 nearest nodes with trilinear weights (float32)."""
    f = (positions - origin) / h
    base = np.floor(f).astype(np.int64)
    t = f - base
    strides = np.array([shape[1] * shape[2], shape[2], 1], dtype=np.int64)
    offsets = np.array(list(np.ndindex(2, 2, 2)), dtype=np.int64) @ strides  # corners in C order
    w = np.stack([1.0 - t, t], axis=2)  # (N, 3, 2): the weights of the lower and upper node
    weight = scale * w[:, 0, :, None, None] * w[:, 1, None, :, None] * w[:, 2, None, None, :]
    index = (base @ strides)[:, None] + offsets
    grid = np.bincount(index.ravel(), weights=weight.ravel(), minlength=math.prod(shape))
    return grid.reshape(shape).astype(np.float32)
