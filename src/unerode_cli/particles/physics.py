"""Numba device functions of one particle (003 §3): random streams, forces, settling, motion,
bounce, detachment and deposition. SI units; vectors are passed as scalar components.

Motion (003 Eq. 5–8). Gravity and buoyancy F = V·g·(ρ_p − ρ_f) (Eq. 5) accelerate the
particle by g_r = −g·(ρ_p − ρ_f)/ρ_p (vertical, z up). Eq. 6/8 say the velocity is this
integral plus the settling velocity w_s plus the medium velocity αv_f. Here that sum is what
Stokes drag relaxes the particle to:

    dv/dt = g_r + (αv_f − v)/τ_s,   τ_s = 2ρ_pR²/(9μ)  (s),

whose terminal velocity is αv_f + g_r·τ_s = αv_f − w_s·ẑ, w_s = (2/9)gR²(ρ_p − ρ_f)/μ: Eq. 7
for an empty particle. Far from terminal (t ≪ τ_s) the particle follows Eq. 5 alone. The
hindered-settling factor f(C) = 1 − (C/C_max)^n of Eq. 7 (Richardson & Zaki) slows the settling
of the particle's *load*, so it enters the deposition law (Eq. 4), not the particle's own fall:
a loaded particle still runs downhill.

Integration: velocity Verlet (003 §4) — positions with the force at the start of the step,
velocities with the mean of the start and end forces — where the linear drag term is integrated
exactly (exponential integrator), because τ_s can be far shorter than the step (small
particles, viscous water), where plain Verlet is unstable. For τ_s → ∞ it is plain velocity
Verlet; for a uniform medium velocity it is the exact solution.
"""

from __future__ import annotations

import math

import numba
import numpy as np

# Indices of the packed parameter vector the kernels read (built by ``simulate``).
P_RADIUS = 0
P_RADIUS_MAX = 1
P_DENSITY = 2
P_RESTITUTION = 3
P_CAPACITY = 4
P_INITIAL_LOAD = 5
P_EXPONENT = 6
P_SHEAR_K = 7
P_SHEAR_LENGTH = 8
P_OMEGA = 9
P_HINDERED = 10
P_STRENGTH = 11
P_RHO_AIR = 12
P_RHO_WATER = 13
P_MU_AIR = 14
P_MU_WATER = 15
P_GRAVITY = 16
P_ALPHA = 17
P_DT = 18
P_LIFETIME = 19
P_REST_SPEED = 20
P_DROP_HEIGHT = 21
P_KEEP_SUSPENDED = 22
P_SEA_LEVEL = 23
N_PARAMS = 24

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S11 = np.uint64(11)
_TWO_M53 = 1.0 / 9007199254740992.0
#: Below this dt/τ_s the exponential factors are evaluated by their series (no cancellation).
_SERIES_BELOW = 1e-4


@numba.njit(cache=True, inline="always")
def mix64(z):
    """The splitmix64 finaliser (Steele, Lea & Flood 2014): a bijective 64-bit hash."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@numba.njit(cache=True)
def stream_key(seed, iteration, index):
    """Start state of the random stream of particle ``index`` of ``iteration`` (all ≥ 0): a
    counter-based hash of the three, so a particle's numbers never depend on the thread or on
    the other particles."""
    k = mix64(np.uint64(seed) + _GOLDEN)
    k = mix64(k ^ (np.uint64(iteration) * _GOLDEN + _M1))
    return mix64(k ^ (np.uint64(index) * _GOLDEN + _M2))


@numba.njit(cache=True, inline="always")
def uniform(state):
    """(next state, uniform number in [0, 1)) of a splitmix64 stream."""
    state = state + _GOLDEN
    return state, float(mix64(state) >> _S11) * _TWO_M53


@numba.njit(cache=True, inline="always")
def hindered(load, c_max, n):
    """Richardson–Zaki hindered-settling factor f(C) = 1 − (C/C_max)^n (003 Eq. 7), in [0, 1]."""
    if load <= 0.0:
        return 1.0
    if c_max <= 0.0:
        return 0.0
    return max(0.0, 1.0 - (load / c_max) ** n)


@numba.njit(cache=True, inline="always")
def settling_velocity(radius, rho_p, rho_f, mu, g, f):
    """Stokes settling speed w_s = (2/9)·g·R²·(ρ_p − ρ_f)/μ·f(C) (m/s, 003 Eq. 7); positive
    downwards (negative for a particle lighter than the medium)."""
    return 2.0 / 9.0 * g * radius * radius * (rho_p - rho_f) / mu * f


@numba.njit(cache=True, inline="always")
def relaxation_time(radius, rho_p, mu):
    """Stokes drag relaxation time τ_s = 2ρ_pR²/(9μ) (s): the time in which the particle's
    velocity relative to its terminal velocity decays by e."""
    return 2.0 * rho_p * radius * radius / (9.0 * mu)


@numba.njit(cache=True, inline="always")
def drag_factors(tau, dt):
    """(φ1, φ2) = (τ(1 − e^{−dt/τ}), τ(dt − φ1)) (s, s²) of a step dt of dv/dt = a − v/τ:
    over the step v gains a·φ1 and x gains v·dt + a·φ2, a the start acceleration. For
    τ → ∞ they tend to (dt, dt²/2), Verlet's; series for small dt/τ avoid cancellation."""
    z = dt / tau
    if z < _SERIES_BELOW:
        return dt * (1.0 - z * (0.5 - z / 6.0)), dt * dt * (0.5 - z * (1.0 / 6.0 - z / 24.0))
    phi1 = -tau * math.expm1(-z)
    return phi1, tau * (dt - phi1)


@numba.njit(cache=True, inline="always")
def advance_position(x, v, u0, acc, tau, dt, phi2):
    """Position after a velocity-Verlet step of dv/dt = acc + (u − v)/τ along one axis, the drag
    integrated exactly (x m, v m/s, acc m/s², τ and dt s, φ2 from ``drag_factors``), with the
    medium velocity ``u0`` at the start point. Exact for a uniform medium."""
    return x + v * dt + (acc + (u0 - v) / tau) * phi2


@numba.njit(cache=True, inline="always")
def advance_velocity(v, um, acc, tau, phi1):
    """Velocity after the same step, with ``um`` the mean medium velocity of the start and end
    points (as Verlet averages the start and end forces)."""
    return v + (acc + (um - v) / tau) * phi1


@numba.njit(cache=True, inline="always")
def shear_stress(speed, k, length):
    """Shear stress τ = K·(v_rel/l)^½ (Pa, 003 Eq. 1 with n = ½)."""
    return k * math.sqrt(speed / length)


@numba.njit(cache=True, inline="always")
def detachment(tau, k_eps, tau_c, a, half_volume):
    """Detached volume q = ε·V½ with ε = K_ε(τ − τ_c)^a (m³, 003 Eq. 2–3); 0 below τ_c."""
    if tau <= tau_c:
        return 0.0
    return k_eps * (tau - tau_c) ** a * half_volume


@numba.njit(cache=True, inline="always")
def deposition(w_s, omega, half_volume):
    """Settled volume q = ω·|w_s|·V½ (m³, 003 Eq. 4 in units of V½, ω in s/m)."""
    return omega * abs(w_s) * half_volume


@numba.njit(cache=True, inline="always")
def bounce(vx, vy, vz, nx, ny, nz, restitution, stick):
    """Velocity after hitting a surface of unit normal n: the incoming normal component is
    reversed and multiplied by the coefficient of restitution, the tangential one kept. An
    incoming normal speed below ``stick`` (m/s, about what the weight adds in one step) is a
    resting contact instead: the normal component is removed and the particle slides.
    Returns (vx, vy, vz, resting contact)."""
    vn = vx * nx + vy * ny + vz * nz
    if vn >= 0.0:
        return vx, vy, vz, False
    resting = -vn <= stick
    k = vn if resting else (1.0 + restitution) * vn
    return vx - k * nx, vy - k * ny, vz - k * nz, resting
