"""Numba tracing of particle batches against a frozen terrain (003 §3–4).

Each particle is emitted, moved (``physics``), detaches and deposits at every impact, and dies
at the domain's edge (its load is lost), when it has settled, or at the end of its lifetime
(it then leaves its load where it is, on the ground below it). Particles are traced in
parallel (``prange``) against a terrain frozen for the batch; what each does to the terrain is
recorded as impact events (x, y, z, Q) in its own row, so the caller applies them in particle
order and the result does not depend on the number of threads. Each particle draws its random
numbers from its own stream, keyed by (seed, iteration, particle index). Per-impact application (003 §3: the
terrain altered at each collision) traces the particles one after the other instead, each
impact applied at once to the ground the tracer reads (``live``: ``LIVE_*``).

The motion is one code path for every representation; only the ground queries (003 §4: is the
particle in the ground, where did its step enter it, the surface point and normal there, the
material) dispatch on the ground kind: ``HEIGHTFIELD`` (a height h(x, y): heightfields and
layered terrains) or ``VOXELS`` (a trilinear level f(x, y, z) > 0 in the ground, ``voxel_kernels``).
A ground value ``g`` follows the particle: the height under it on a heightfield, f at it on voxels.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from unerode_cli.particles import physics as ph
from unerode_cli.particles import terrain_kernels as tk
from unerode_cli.particles import voxel_kernels as vk
from unerode_cli.particles.emission import RAIN
from unerode_cli.particles.medium import MEANDER, NONE, UNIFORM
from unerode_cli.volume import voxel_kernels as vox

SETTLED, EDGE, EXPIRED = 0, 1, 2
#: Ground kinds of the tracer (``TracingSnapshot.kind``).
HEIGHTFIELD, VOXELS = 0, 1
#: Columns of the per-particle budget: volumes (m³) carried in at emission, detached,
#: deposited (impacts and death), lost at the edge, kept in suspension at death, and the part
#: of the deposit left where the particle died.
B_EMITTED, B_DETACHED, B_DEPOSITED, B_LOST, B_SUSPENDED, B_DROPPED = 0, 1, 2, 3, 4, 5
N_BUDGET = 6
#: Per-impact application (``live[0]``): off (frozen terrain, parallel), or impacts applied at
#: once to a heightfield, to density voxels or to binary voxels (serial).
LIVE_OFF, LIVE_HEIGHTFIELD, LIVE_DENSITY, LIVE_BINARY = 0, 1, 2, 3


def live_off():
    """The ``live`` argument of a frozen terrain (its arrays unused)."""
    return (LIVE_OFF, np.zeros((0, 0, 0)), np.zeros((0, 0, 0), np.bool_), np.zeros((0, 0, 0), np.int32), 0.0,
            0, (-1, np.zeros(1, np.int16), np.zeros(0)), np.zeros(1), np.zeros(vox.N_COUNTERS, np.int64))


@numba.njit(cache=True, inline="always")
def _field(kind, medium, scalars, bands, x, y, in_water, dx, dy, alpha):
    """Medium velocity α·v_f (m/s, kernel axes) at (x, y) in the medium there (003 Eq. 8)."""
    if kind == NONE or (medium == 1 and in_water) or (medium == 2 and not in_water):
        return 0.0, 0.0, 0.0
    if kind == UNIFORM:
        return alpha * scalars[0], alpha * scalars[1], alpha * scalars[2]
    if kind == MEANDER:  # northward amplitude·sin(2πx/λ); kernel y points south
        return 0.0, -alpha * scalars[0] * math.sin(2.0 * math.pi * x / scalars[1]), 0.0
    ny, nx = bands.shape[1], bands.shape[2]
    r = min(max(int(round(y / dy)), 0), ny - 1)
    c = min(max(int(round(x / dx)), 0), nx - 1)
    return alpha * bands[0, r, c], alpha * bands[1, r, c], alpha * bands[2, r, c]


@numba.njit(cache=True, inline="always")
def _move(x, y, z, vx, vy, vz, ax, ay, az, tau_s, dt, phi1, phi2, sea, fkind, fmedium, fscal, fbands,
          dx, dy, alpha):
    """One step dt (s) of the motion (003 Eq. 5–8, ``physics``) under the net weight per unit
    mass (ax, ay, az) (m/s²), with (φ1, φ2) = ``physics.drag_factors(tau_s, dt)``.
    Returns (x, y, z, vx, vy, vz)."""
    ux, uy, uz = _field(fkind, fmedium, fscal, fbands, x, y, z < sea, dx, dy, alpha)
    x1 = ph.advance_position(x, vx, ux, ax, tau_s, dt, phi2)
    y1 = ph.advance_position(y, vy, uy, ay, tau_s, dt, phi2)
    z1 = ph.advance_position(z, vz, uz, az, tau_s, dt, phi2)
    wx, wy, wz = ux, uy, uz
    if fkind != NONE:
        wx, wy, wz = _field(fkind, fmedium, fscal, fbands, x1, y1, z1 < sea, dx, dy, alpha)
    return (x1, y1, z1, ph.advance_velocity(vx, 0.5 * (ux + wx), ax, tau_s, phi1),
            ph.advance_velocity(vy, 0.5 * (uy + wy), ay, tau_s, phi1),
            ph.advance_velocity(vz, 0.5 * (uz + wz), az, tau_s, phi1))


@numba.njit(cache=True, inline="always")
def _segment(cdf, u):
    """Index of the first cumulative weight > u (clamped to the last one)."""
    return min(np.searchsorted(cdf, u, side="right"), cdf.size - 1)


@numba.njit(cache=True)
def _emit(state, h, dx, dy, phys, ekind, ecdf, ecells, epts, espread):
    """Draw a particle's radius (m) and start position (m). Returns (state, R, x, y, z)."""
    nx = h.shape[1]
    radius = phys[ph.P_RADIUS]
    state, u = ph.uniform(state)
    if phys[ph.P_RADIUS_MAX] > radius:
        radius += u * (phys[ph.P_RADIUS_MAX] - radius)
    if ekind == RAIN:
        state, u = ph.uniform(state)
        cell = ecells[_segment(ecdf, u)]
        state, u1 = ph.uniform(state)
        state, u2 = ph.uniform(state)
        x = (cell % nx - 0.5 + u1) * dx
        y = (cell // nx - 0.5 + u2) * dy
    else:
        x, y = epts[0, 0], epts[0, 1]
        if epts.shape[0] > 1 and ecdf[ecdf.size - 1] > 0.0:
            state, u = ph.uniform(state)
            j = _segment(ecdf, u)
            lower = ecdf[j - 1] if j > 0 else 0.0
            frac = (u - lower) / (ecdf[j] - lower)
            x = epts[j, 0] + frac * (epts[j + 1, 0] - epts[j, 0])
            y = epts[j, 1] + frac * (epts[j + 1, 1] - epts[j, 1])
        if espread > 0.0:
            state, u1 = ph.uniform(state)
            state, u2 = ph.uniform(state)
            rho = espread * math.sqrt(u1)
            x += rho * math.cos(2.0 * math.pi * u2)
            y += rho * math.sin(2.0 * math.pi * u2)
    z = tk.height(h, x, y, dx, dy) + phys[ph.P_DROP_HEIGHT]
    return state, radius, x, y, z


@numba.njit(cache=True, inline="always")
def _ground(gkind, h, vol, z0, dz, col, row, z):
    """The ground value at grid coordinates (col, row) and elevation z (m): the height (m) of a
    heightfield, the level f of voxels (> 0 in the ground)."""
    if gkind == HEIGHTFIELD:
        return tk.height_at(h, col, row)
    return vk.level_at(vol, col, row, (z - z0) / dz - 0.5)


@numba.njit(cache=True, inline="always")
def _in_ground(gkind, g, z):
    """Whether a particle at elevation z (m) with ground value g is on or in the ground."""
    if gkind == HEIGHTFIELD:
        return z <= g
    return g >= 0.0


@numba.njit(cache=True, inline="always")
def _entry(gkind, g0, z0, g1, z1):
    """Fraction of a step from (ground value g0, elevation z0) to (g1, z1) at which the particle
    enters the ground (the ground values interpolated linearly along the step), or −1 when it
    does not enter it (it did not start strictly above it or did not end strictly in it)."""
    if gkind == HEIGHTFIELD:
        above = z0 - g0
        if above > 0.0 and g1 > z1:
            return above / (above + g1 - z1)
        return -1.0
    if g0 < 0.0 and g1 > 0.0:
        return g0 / (g0 - g1)
    return -1.0


@numba.njit(cache=True, inline="always")
def _onto(gkind, h, vol, x, y, z, g, dx, dy, dz, z0):
    """The surface point of a particle at (x, y, z) (m) with ground value g and the ground's
    unit outward normal there: straight up onto a heightfield, along ∇f onto the voxels' f = 0
    level (003 §4: intersection and normal). Returns (x, y, z, g, n_x, n_y, n_z)."""
    if gkind == HEIGHTFIELD:
        nx_, ny_, nz_ = tk.normal_at(h, x / dx, y / dy, dx, dy)
        return x, y, g, g, nx_, ny_, nz_
    x, y, z, nx_, ny_, nz_ = vk.project(vol, x, y, z, dx, dy, dz, z0)
    return x, y, z, 0.0, nx_, ny_, nz_


@numba.njit(cache=True, inline="always")
def _down_onto(gkind, h, vol, x, y, z, g, dx, dy, dz, z0):
    """After a step cut where it meets the ground: a particle left above the surface (the
    interpolation of the cut is linear) is put onto it, one in the ground stays there (the
    impact puts it onto the surface). Returns (x, y, z, g)."""
    if gkind == HEIGHTFIELD:
        return x, y, min(z, g), g
    if g < 0.0:
        x, y, z, g, _, _, _ = _onto(gkind, h, vol, x, y, z, g, dx, dy, dz, z0)
    return x, y, z, g


@numba.njit(cache=True)
def _apply_live(live, h, valid, vol, vmat, dx, dy, dz, z0, x, y, z, q, radius):
    """Apply an impact (x, y, z in m, Q m³ > 0 deposits, R m) at once to the ground the tracer
    reads (per-impact application): ``live`` = (mode ``LIVE_*``, density float64[rows,
    columns, layers], solid mask, hit counts, α, C, material rules, float64[1] matter that left
    the grid (m³), int64 counters of binary voxels); the material index is ``vmat``. A
    heightfield takes 003 Eq. 9 as ``terrain_kernels.apply_heightfield`` does; voxels take
    ``volume.voxel_kernels.density_event`` / ``binary_event``, then the tracer's level and top
    surface are refreshed around the impact."""
    mode, f, solid, hits, alpha, threshold, rules, left, counters = live
    if mode == LIVE_HEIGHTFIELD:
        rows, cols, weights = tk.footprint_buffers(radius, dx, dy)
        count, total = tk.footprint(valid, x, y, radius, dx, dy, rows, cols, weights)
        scale = q / (dx * dy * total)
        for k in range(count):
            h[rows[k], cols[k]] += scale * weights[k]
        return
    index, weight = vox.sphere_buffers(radius, dx, dy, dz)
    if mode == LIVE_DENSITY:
        left[0] += vox.density_event(f, vmat, valid, dx, dy, dz, z0, x, y, z, q, radius, rules, index, weight)
        vk.refresh(vol, h, valid, f, False, x, y, radius, dx, dy, z0, dz)
    else:
        vox.binary_event(solid, hits, vmat, valid, dx, dy, dz, z0, x, y, z, q, radius, alpha, threshold,
                         rules, index, weight, counters)
        vk.refresh(vol, h, valid, solid, True, x, y, radius, dx, dy, z0, dz)


@numba.njit(cache=True, inline="always")
def _record(path, n, stride_hit, x, y, z, t, dx, dy):
    """Append (column, row, z, t) to a path buffer when ``stride_hit``; returns the new length.
    A full buffer keeps its last slot for the final point."""
    if path.shape[0] == 0 or not stride_hit:
        return n
    k = min(n, path.shape[0] - 1)
    path[k, 0], path[k, 1], path[k, 2], path[k, 3] = x / dx, y / dy, z, t
    return k + 1


@numba.njit(cache=True)
def trace_particle(index, iteration, seed, phys, h, valid, mat, keps, tauc, dx, dy,
                   gkind, vol, vmat, z0, dz,
                   fkind, fmedium, fscal, fbands, ekind, ecdf, ecells, epts, espread, ev0,
                   events, budget, path, path_stride, live):
    """Trace particle ``index`` of ``iteration`` from emission to death on the frozen terrain,
    or with ``live`` (``_apply_live``) on one that each of its impacts alters at once.

    The ground: ``gkind`` ``HEIGHTFIELD`` reads the height ``h`` and the material index ``mat``
    per cell; ``VOXELS`` reads the level ``vol`` (float32[rows, columns, layers], layer k's
    centre at z0 + (k + ½)·dz m) and the material index ``vmat`` per voxel (empty: material 0),
    ``h`` being then its top surface (where particles are emitted) and a particle below z0
    leaving the domain. ``keps``, ``tauc``: K_ε and τ_c of each material (003 Eq. 2).

    Writes its impacts (x, y, z, Q in m, m, m, m³; Q > 0 deposits) into ``events`` while there
    is room (the count goes on), its volumes into ``budget`` (columns ``B_*``) and, when
    ``path`` has rows, its path (column, row, z m, t s) every ``path_stride`` steps and at death.

    Returns (number of events, radius R (m), fate, number of impacts, path length).

    Kept whole: one loop over the particle's life whose state (position, grid coordinates,
    velocity, ground level, surface normal, contact flags, load, event count, time, step and the
    drag factors memoised for the last step and medium) lives in some twenty locals that both
    halves of each pass, the impact and the step, read and rewrite; the parts that need no such
    state are helpers already (``_emit``, ``_onto``, ``_move``, ``_ground``, ``_entry``,
    ``_down_onto``, ``_record``, ``_apply_live``), and a split would pass that state in and out
    as long tuples.
    """
    ny, nx = h.shape
    state, radius, x, y, z = _emit(ph.stream_key(seed, iteration, index), h, dx, dy, phys,
                                   ekind, ecdf, ecells, epts, espread)
    vx, vy, vz = ev0[0], ev0[1], ev0[2]
    rho_p, g, sea = phys[ph.P_DENSITY], phys[ph.P_GRAVITY], phys[ph.P_SEA_LEVEL]
    n_hind, alpha = phys[ph.P_HINDERED], phys[ph.P_ALPHA]
    omega, shear_k, shear_l = phys[ph.P_OMEGA], phys[ph.P_SHEAR_K], phys[ph.P_SHEAR_LENGTH]
    exponent, restitution = phys[ph.P_EXPONENT], phys[ph.P_RESTITUTION]
    lifetime, max_dt, rest_speed = phys[ph.P_LIFETIME], phys[ph.P_DT], phys[ph.P_REST_SPEED]
    # what depends on the medium only (index 0 air, 1 water), evaluated once per particle:
    # relaxation time τ_s (s), net weight per unit mass (m/s²), settling speed of an empty
    # particle (m/s; × f(C) at an impact) and resting-contact speed per second of step (m/s²)
    rho_f2 = (phys[ph.P_RHO_AIR], phys[ph.P_RHO_WATER])
    mu2 = (phys[ph.P_MU_AIR], phys[ph.P_MU_WATER])
    tau2 = (ph.relaxation_time(radius, rho_p, mu2[0]), ph.relaxation_time(radius, rho_p, mu2[1]))
    acc2 = (-g * (rho_p - rho_f2[0]) / rho_p, -g * (rho_p - rho_f2[1]) / rho_p)
    settle2 = (ph.settling_velocity(radius, rho_p, rho_f2[0], mu2[0], g, 1.0),
               ph.settling_velocity(radius, rho_p, rho_f2[1], mu2[1], g, 1.0))
    stick2 = (2.0 * g * abs(rho_p - rho_f2[0]) / rho_p, 2.0 * g * abs(rho_p - rho_f2[1]) / rho_p)
    half = 2.0 / 3.0 * math.pi * radius ** 3 * phys[ph.P_STRENGTH]
    c_max = phys[ph.P_CAPACITY] * half
    load = phys[ph.P_INITIAL_LOAD] * c_max
    budget[B_EMITTED] = load
    max_move = 0.5 * min(dx, dy, dz)
    t = 0.0
    dt = phys[ph.P_DT]
    step = 0
    count = 0
    impacts = 0
    fate = EXPIRED
    n_path = _record(path, 0, True, x, y, z, t, dx, dy)
    col, row = x / dx, y / dy  # grid coordinates of (x, y), kept along with them
    ground = _ground(gkind, h, vol, z0, dz, col, row, z)
    touching = False  # the last step was cut where it met the ground
    sliding = False
    nxn, nyn, nzn = 0.0, 0.0, 1.0
    tau_memo, dt_memo, phi1, phi2 = -1.0, -1.0, 0.0, 0.0
    while True:
        c = min(max(int(round(col)), 0), nx - 1)
        r = min(max(int(round(row)), 0), ny - 1)
        if col < -0.5 or col > nx - 0.5 or row < -0.5 or row > ny - 0.5 or not valid[r, c] or z < z0:
            fate = EDGE
            break
        if touching or _in_ground(gkind, ground, z):
            # impact: onto the surface, detachment and deposition (003 Eq. 1–4), then the bounce
            touching = False
            impacts += 1
            x, y, z, ground, nxn, nyn, nzn = _onto(gkind, h, vol, x, y, z, ground, dx, dy, dz, z0)
            col, row = x / dx, y / dy
            medium = 1 if z < sea else 0
            w_s = settle2[medium] * ph.hindered(load, c_max, n_hind)
            q_dep = min(ph.deposition(w_s, omega, half), load)
            speed = math.sqrt(vx * vx + vy * vy + vz * vz)
            tau = ph.shear_stress(speed, shear_k, shear_l)
            if gkind == HEIGHTFIELD:
                m = mat[r, c]
            else:
                m = vk.material_at(vmat, x, y, z, nxn, nyn, nzn, dx, dy, dz, z0)
            q_det = ph.detachment(tau, keps[m], tauc[m], exponent, half)
            q_det = min(q_det, max(0.0, c_max - (load - q_dep)))
            load = load - q_dep + q_det
            budget[B_DETACHED] += q_det
            budget[B_DEPOSITED] += q_dep
            if q_dep != q_det:
                if count < events.shape[0]:
                    events[count, 0], events[count, 1], events[count, 2] = x, y, z
                    events[count, 3] = q_dep - q_det
                count += 1
                if live[0] != LIVE_OFF:  # the particle goes on from the altered surface
                    _apply_live(live, h, valid, vol, vmat, dx, dy, dz, z0, x, y, z, q_dep - q_det, radius)
                    ground = _ground(gkind, h, vol, z0, dz, col, row, z)
                    x, y, z, ground, _, _, _ = _onto(gkind, h, vol, x, y, z, ground, dx, dy, dz, z0)
                    col, row = x / dx, y / dy
            # resting contact below twice the normal speed the weight added in the last step
            stick = stick2[medium] * dt
            vx, vy, vz, sliding = ph.bounce(vx, vy, vz, nxn, nyn, nzn, restitution, stick)
            if math.sqrt(vx * vx + vy * vy + vz * vz) < rest_speed:
                fate = SETTLED
                break
        if t >= lifetime:
            break
        # one step of the motion (003 Eq. 5–8) in the medium at the particle
        medium = 1 if z < sea else 0
        tau_s = tau2[medium]
        acc = acc2[medium]
        ax, ay, az = 0.0, 0.0, acc
        if sliding:  # in resting contact only the weight's component along the ground acts
            ax, ay, az = -acc * nzn * nxn, -acc * nzn * nyn, acc * (1.0 - nzn * nzn)
            sliding = False
        dt = min(max_dt, lifetime - t)
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        if speed * dt > max_move:
            dt = max_move / speed
        if tau_s != tau_memo or dt != dt_memo:  # the exponentials only when the step or medium changed
            tau_memo, dt_memo = tau_s, dt
            phi1, phi2 = ph.drag_factors(tau_s, dt)
        x1, y1, z1, vx1, vy1, vz1 = _move(x, y, z, vx, vy, vz, ax, ay, az, tau_s, dt, phi1, phi2, sea,
                                          fkind, fmedium, fscal, fbands, dx, dy, alpha)
        col, row = x1 / dx, y1 / dy
        ground1 = _ground(gkind, h, vol, z0, dz, col, row, z1)
        frac = _entry(gkind, ground, z, ground1, z1)
        if frac >= 0.0:  # end the step where it meets the ground (no tunnelling)
            dt *= frac
            tau_memo, dt_memo = tau_s, dt
            phi1, phi2 = ph.drag_factors(tau_s, dt)
            x1, y1, z1, vx1, vy1, vz1 = _move(x, y, z, vx, vy, vz, ax, ay, az, tau_s, dt, phi1, phi2, sea,
                                              fkind, fmedium, fscal, fbands, dx, dy, alpha)
            col, row = x1 / dx, y1 / dy
            ground1 = _ground(gkind, h, vol, z0, dz, col, row, z1)
            x1, y1, z1, ground1 = _down_onto(gkind, h, vol, x1, y1, z1, ground1, dx, dy, dz, z0)
            col, row = x1 / dx, y1 / dy
            touching = True
        ground = ground1
        vx, vy, vz = vx1, vy1, vz1
        x, y, z = x1, y1, z1
        t += dt
        step += 1
        n_path = _record(path, n_path, step % path_stride == 0, x, y, z, t, dx, dy)
    if fate == EDGE:
        budget[B_LOST] = load
    else:
        keep = load * phys[ph.P_KEEP_SUSPENDED]
        budget[B_SUSPENDED] = keep
        put = load - keep
        if put > 0.0:
            zg = z  # a particle that dies in flight leaves its load on the ground below
            if gkind != HEIGHTFIELD:
                zg = vk.ground_below(vol, x, y, z, dx, dy, dz, z0)
            budget[B_DEPOSITED] += put
            budget[B_DROPPED] = put
            if count < events.shape[0]:
                events[count, 0], events[count, 1], events[count, 2], events[count, 3] = x, y, zg, put
            count += 1
            if live[0] != LIVE_OFF:
                _apply_live(live, h, valid, vol, vmat, dx, dy, dz, z0, x, y, zg, put, radius)
    if step % path_stride != 0:
        n_path = _record(path, n_path, True, x, y, z, t, dx, dy)
    return count, radius, fate, impacts, n_path


@numba.njit(cache=True)
def _trace_row(i, indices, iteration, seed, phys, h, valid, mat, keps, tauc, dx, dy, gkind, vol, vmat, z0,
               dz, fkind, fmedium, fscal, fbands, ekind, ecdf, ecells, epts, espread, ev0, events, path_slot,
               path_buf, path_stride, live, no_path, counts, radii, fates, impacts, budget, path_len):
    """Trace particle ``indices[i]`` of a batch into row i of ``trace_batch``'s results."""
    slot = path_slot[i]
    path = path_buf[slot] if slot >= 0 else no_path
    count, radius, fate, n_imp, n_path = trace_particle(
        indices[i], iteration, seed, phys, h, valid, mat, keps, tauc, dx, dy,
        gkind, vol, vmat, z0, dz, fkind, fmedium, fscal, fbands, ekind, ecdf, ecells, epts, espread, ev0,
        events[i], budget[i], path, path_stride, live)
    counts[i] = count
    radii[i] = radius
    fates[i] = fate
    impacts[i] = n_imp
    if slot >= 0:
        path_len[slot] = n_path


@numba.njit(cache=True, parallel=True)
def trace_batch(indices, iteration, seed, phys, h, valid, mat, keps, tauc, dx, dy,
                gkind, vol, vmat, z0, dz, fkind, fmedium, fscal, fbands, ekind, ecdf, ecells, epts, espread,
                ev0, events, path_slot, path_buf, path_stride, live):
    """Trace the particles ``indices`` (int64[n], indices within ``iteration``) in parallel on
    the frozen terrain, or one after the other in their order when ``live`` applies each
    impact at once (the terrain's arguments are those of ``trace_particle``).

    Args:
        events: float64[≥ n, capacity, 4] buffer (its content is overwritten; the caller keeps
            it from batch to batch) for the events of particle i in row i; a particle with
            more than ``capacity`` events reports its full count, and the caller traces it
            again with a larger buffer (the result is the same: the terrain is frozen and the
            particle's random stream is its own). Per-impact application needs no events.
        path_slot: int64[n], row of ``path_buf`` (float64[k, m, 4]) to record the particle's
            path into, or −1.

    Returns:
        (events (the buffer), counts int64[n], radii float64[n], fates int8[n],
        impacts int64[n], budget float64[n, N_BUDGET], path lengths int64[k]).
    """
    n = indices.size
    counts = np.zeros(n, np.int64)
    radii = np.zeros(n)
    fates = np.zeros(n, np.int8)
    impacts = np.zeros(n, np.int64)
    budget = np.zeros((n, N_BUDGET))
    path_len = np.zeros(path_buf.shape[0], np.int64)
    no_path = np.zeros((0, 4))
    # a parallel loop takes arrays, not tuples of them: the live state goes in unpacked
    mode, f, solid, hits, alpha, threshold, (deposit, on_erosion, erodibility), left, n_hits = live
    parallel = mode == LIVE_OFF
    for i in numba.prange(n if parallel else 0):
        _trace_row(i, indices, iteration, seed, phys, h, valid, mat, keps, tauc, dx, dy, gkind, vol, vmat, z0,
                   dz, fkind, fmedium, fscal, fbands, ekind, ecdf, ecells, epts, espread, ev0, events,
                   path_slot, path_buf, path_stride,
                   (mode, f, solid, hits, alpha, threshold, (deposit, on_erosion, erodibility), left, n_hits),
                   no_path, counts, radii, fates, impacts, budget, path_len)
    for i in range(0 if parallel else n):
        _trace_row(i, indices, iteration, seed, phys, h, valid, mat, keps, tauc, dx, dy, gkind, vol, vmat, z0,
                   dz, fkind, fmedium, fscal, fbands, ekind, ecdf, ecells, epts, espread, ev0, events,
                   path_slot, path_buf, path_stride, live, no_path, counts, radii, fates, impacts, budget,
                   path_len)
    return events, counts, radii, fates, impacts, budget, path_len


@numba.njit(cache=True)
def flatten(events, counts, radii, retraced_row, retraced_events):
    """Events of a batch in particle order as columns (x, y, z, Q, R): float64[Σ counts, 5].
    ``retraced_row[i]`` ≥ 0 takes particle i's events from that row of ``retraced_events``."""
    out = np.empty((counts.sum(), 5))
    k = 0
    for i in range(counts.size):
        src = events[i] if retraced_row[i] < 0 else retraced_events[retraced_row[i]]
        for j in range(counts[i]):
            out[k, 0], out[k, 1], out[k, 2], out[k, 3] = src[j, 0], src[j, 1], src[j, 2], src[j, 3]
            out[k, 4] = radii[i]
            k += 1
    return out
