"""The wind around the rock by an incompressible flow solver: lattice Boltzmann, D3Q19 (002 §5).

002 computes the local wind by divergence-free SPH around the rock. This module solves the same
incompressible Navier–Stokes flow on a voxel grid with the lattice Boltzmann method (D3Q19
lattice, BGK collision; Krüger et al. 2017, The Lattice Boltzmann Method, ch. 3–5), which
gives what SPH gives the abrasion of Eq. 8 — the speed-up around edges, the wake, the
recirculation that brings wind back onto leeward faces — on the rock's own voxels, with no
particle sampling of the air, at a cost per cell and step that numba runs on two cores. The flow
is weakly compressible (Mach number u·√3 ≈ 0.1, density changes of ~1 %).

Set-up (lattice units: cell 1, step 1): ``solid`` voxels (the rock) reflect by halfway
bounce-back (no slip); the ground below the grid reflects specularly (free slip, no boundary
layer); every other face of the domain is far field: the populations entering from it are those
of the free wind (equilibrium at density 1, velocity ``u_lattice``·d), also where the wind
leaves. The kinematic viscosity follows from the Reynolds number Re = u·L/ν of the rock's
width L (cells): τ = ½ + 3ν. Real winds around rocks have Re ~ 10⁶–10⁷; a BGK lattice stays
stable down to τ ≈ 0.52, so the flow here is that of a moderate Re (~ 100, ``MIN_TAU``):
laminar, with a steady recirculating wake behind a bluff body — the same topology as the
time-averaged turbulent wake, shorter and weaker.

Validation (``tests/sandstone/test_airflow.py``): the drag coefficient of a sphere at Re = 100,
C_d = 1.09 (Clift, Grace & Weber 1978; Schiller–Naumann), and its recirculation length behind
the sphere, 0.87 D at Re = 100 (Taneda 1956).
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: D3Q19 velocities (c_x, c_y, c_z) and weights; index 0 is the rest population.
C = np.array([(0, 0, 0),
              (1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1),
              (1, 1, 0), (-1, -1, 0), (1, -1, 0), (-1, 1, 0),
              (1, 0, 1), (-1, 0, -1), (1, 0, -1), (-1, 0, 1),
              (0, 1, 1), (0, -1, -1), (0, 1, -1), (0, -1, 1)], dtype=np.int64)
W = np.array([1 / 3] + [1 / 18] * 6 + [1 / 36] * 12)
#: The opposite of each direction, and its mirror image in a horizontal plane (c_z → −c_z).
OPPOSITE = np.array([int(np.flatnonzero((C == -c).all(axis=1))[0]) for c in C], dtype=np.int64)
MIRROR_Z = np.array([int(np.flatnonzero((C == c * np.array([1, 1, -1])).all(axis=1))[0]) for c in C],
                    dtype=np.int64)
#: Lattice speed of the free wind (cells per step): Mach u·√3 ≈ 0.1.
U_LATTICE = 0.06
#: Smallest relaxation time taken: the BGK lattice round sharp-edged rock is unstable at τ = 0.518
#: (an 8 m cube on 10 cells) and stable at 0.529 (16 cells).
MIN_TAU = 0.525


def relaxation_time(reynolds: float, width: float, u_lattice: float = U_LATTICE) -> float:
    """BGK relaxation time τ for Re = u·width/ν (width in cells): τ = ½ + 3ν."""
    return 0.5 + 3.0 * u_lattice * width / reynolds


def equilibrium(density: float, velocity: np.ndarray) -> np.ndarray:
    """The 19 equilibrium populations of a uniform state (float64[19])."""
    cu = C @ np.asarray(velocity, dtype=np.float64)
    uu = float(np.dot(velocity, velocity))
    return W * density * (1.0 + 3.0 * cu + 4.5 * cu * cu - 1.5 * uu)


@numba.njit(cache=True, parallel=True)
def _step(f, g, solid, tau, inflow, c, w, opposite, mirror, force):
    """One stream (pull) + collide step from populations f into g (float64[19, nx, ny, nz]);
    ``force`` (float64[nx, 3]) receives, per x slab, the momentum the solid takes this step."""
    q, nx, ny, nz = f.shape
    omega = 1.0 / tau
    for x in numba.prange(nx):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        local = np.empty(q)
        for y in range(ny):
            for z in range(nz):
                if solid[x, y, z]:
                    for i in range(q):
                        g[i, x, y, z] = 0.0
                    continue
                for i in range(q):
                    sx, sy, sz = x - c[i, 0], y - c[i, 1], z - c[i, 2]
                    if sz < 0:  # from below the ground: specular reflection
                        j = mirror[i]
                        sx, sy, sz = x - c[j, 0], y - c[j, 1], 0
                        if sx < 0 or sy < 0 or sx >= nx or sy >= ny:
                            local[i] = inflow[i]
                        elif solid[sx, sy, sz]:
                            local[i] = f[opposite[j], x, y, z]
                        else:
                            local[i] = f[j, sx, sy, sz]
                    elif sx < 0 or sy < 0 or sx >= nx or sy >= ny or sz >= nz:
                        local[i] = inflow[i]
                    elif solid[sx, sy, sz]:  # halfway bounce-back off the rock
                        value = f[opposite[i], x, y, z]
                        local[i] = value
                        # the link carried 2·f_opp·c_opp into the solid
                        fx -= 2.0 * value * c[i, 0]
                        fy -= 2.0 * value * c[i, 1]
                        fz -= 2.0 * value * c[i, 2]
                    else:
                        local[i] = f[i, sx, sy, sz]
                rho = 0.0
                ux = 0.0
                uy = 0.0
                uz = 0.0
                for i in range(q):
                    v = local[i]
                    rho += v
                    ux += v * c[i, 0]
                    uy += v * c[i, 1]
                    uz += v * c[i, 2]
                ux /= rho
                uy /= rho
                uz /= rho
                uu = 1.5 * (ux * ux + uy * uy + uz * uz)
                for i in range(q):
                    cu = 3.0 * (c[i, 0] * ux + c[i, 1] * uy + c[i, 2] * uz)
                    feq = w[i] * rho * (1.0 + cu + 0.5 * cu * cu - uu)
                    g[i, x, y, z] = local[i] + omega * (feq - local[i])
        force[x, 0] = fx
        force[x, 1] = fy
        force[x, 2] = fz


@numba.njit(cache=True, parallel=True)
def _velocity(f, solid, c):
    """Velocity (float64[nx, ny, nz, 3], cells per step) of populations f; 0 in the solid."""
    q, nx, ny, nz = f.shape
    out = np.zeros((nx, ny, nz, 3))
    for x in numba.prange(nx):
        for y in range(ny):
            for z in range(nz):
                if solid[x, y, z]:
                    continue
                rho = 0.0
                ux = 0.0
                uy = 0.0
                uz = 0.0
                for i in range(q):
                    v = f[i, x, y, z]
                    rho += v
                    ux += v * c[i, 0]
                    uy += v * c[i, 1]
                    uz += v * c[i, 2]
                out[x, y, z, 0] = ux / rho
                out[x, y, z, 1] = uy / rho
                out[x, y, z, 2] = uz / rho
    return out


class Airflow:
    """The flow of the free wind ``direction`` (unit vector, x east, y north, z up; blowing
    toward) around the ``solid`` voxels (bool[nx, ny, nz]) at Reynolds number ``reynolds`` for
    the body width ``width`` (cells). ``run(steps)`` advances it (warm: a later call continues
    from the last state, e.g. after the solid changed); ``velocity()`` is the flow in units of
    the free wind's speed."""

    def __init__(self, solid: np.ndarray, direction: np.ndarray, reynolds: float, width: float,
                 u_lattice: float = U_LATTICE) -> None:
        self.solid = np.ascontiguousarray(solid, dtype=np.bool_)
        d = np.asarray(direction, dtype=np.float64)
        self.u_lattice = u_lattice
        self.inflow_velocity = u_lattice * d / np.linalg.norm(d)
        self.tau = relaxation_time(reynolds, width, u_lattice)
        if self.tau < MIN_TAU:
            raise ValueError(f"Re = {reynolds:g} over {width:g} cells needs τ = {self.tau:.4f} < {MIN_TAU}, "
                             "which the BGK lattice does not keep stable around sharp rock; use a lower Re "
                             "or more cells across the rock")
        self.inflow = equilibrium(1.0, self.inflow_velocity)
        shape = (19, *self.solid.shape)
        self.f = np.empty(shape)
        self.f[:] = self.inflow[:, None, None, None]
        self.g = np.empty(shape)
        self.force = np.zeros((self.solid.shape[0], 3))
        self.steps = 0

    def set_solid(self, solid: np.ndarray) -> None:
        """Change the solid (the rock eroded): newly opened voxels start as free wind."""
        solid = np.ascontiguousarray(solid, dtype=np.bool_)
        opened = self.solid & ~solid
        self.f[:, opened] = self.inflow[:, None]
        self.solid = solid

    def run(self, steps: int) -> None:
        """Advance ``steps`` lattice steps; FloatingPointError if the flow blew up."""
        for _ in range(steps):
            _step(self.f, self.g, self.solid, self.tau, self.inflow, C, W, OPPOSITE, MIRROR_Z, self.force)
            self.f, self.g = self.g, self.f
        self.steps += steps
        if not np.isfinite(self.force).all():
            raise FloatingPointError(f"the wind flow blew up after {self.steps} steps (τ = {self.tau:.4f})")

    def drag(self) -> np.ndarray:
        """Force on the solid in the last step (lattice units: density·cells⁴/step²), float64[3]."""
        return self.force.sum(axis=0)

    def velocity(self) -> np.ndarray:
        """float64[nx, ny, nz, 3]: the flow velocity over the free wind's speed (1 in the free
        stream; 0 in the solid)."""
        return _velocity(self.f, self.solid, C) / self.u_lattice


def flow_through_steps(length: float, u_lattice: float = U_LATTICE) -> int:
    """Steps for the free wind to cross ``length`` cells once."""
    return int(math.ceil(length / u_lattice))
