"""Declared parameters of particle erosion (003 §3–4): units, defaults, valid ranges.

This module does not import numba, so that the command line can show its help fast.

Units and how they read the paper's equations (003 is written in a "dimensionless
framework", §4; here every quantity carries an SI unit):

- Volumes of one impact are counted in half-spheres V½ = 2πR³/3 (Eq. 3) times ``strength``:
  detachment ε·V½ (ε = K_ε(τ − τ_c)^a dimensionless, Eq. 2–3), deposition ω·|w_s|·V½ (Eq. 4,
  so ω is in s/m) and the capacity C_max = C_factor·V½ (Table 1's capacity factor).
- Shear stress τ = K·(v_rel/l)^½ (Eq. 1, n = ½) in Pa, K in Pa·s^½, l in m.
- Settling w_s = (2/9)·g·R²·(ρ_p − ρ_f)/μ·f(C) (Eq. 7). Stokes' law with metre-sized particles
  and the real viscosity of air (1.8e-5 Pa·s) gives settling speeds of 1e8 m/s, so μ here is an
  *effective* viscosity (defaults below: a rain particle of Table 1, R = 20 m, ρ_p = 1000 kg/m³,
  relaxes in 2ρ_pR²/(9μ) ≈ 2 s in air and settles at ≈ 20 m/s; water keeps the real
  water/air viscosity ratio, 1.0e-3 / 1.8e-5 ≈ 55).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from unerode_cli.grid import Grid
from unerode_cli.processes.parameters import ParamSpec, check_fields

#: Effective dynamic viscosity of air (Pa·s), see the module docstring.
MU_AIR = 4.4e4
#: Real viscosity ratio water/air at 20 °C (1.0e-3 Pa·s / 1.8e-5 Pa·s).
WATER_AIR_VISCOSITY_RATIO = 55.0

PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("radius", "m", 20.0, "particle radius R: the half-sphere one impact alters (003 Eq. 3, 9)",
              minimum=0.0, symbol="R"),
    ParamSpec("radius_max", "m", 0.0,
              "when > radius, each particle's R is drawn uniformly in [radius, radius_max] "
              "(003 River: 1.5-5 cells); 0 = every particle has R = radius", minimum=0.0),
    ParamSpec("density", "kg/m³", 1000.0, "particle density ρ_p (003 Eq. 5, Table 1)", minimum=0.0,
              symbol="rho_p"),
    ParamSpec("restitution", "1", 1.0,
              "coefficient of restitution: the normal speed is multiplied by it at a bounce (003 §3.3)",
              minimum=0.0, maximum=1.0, symbol="COR"),
    ParamSpec("capacity", "1", 10.0,
              "capacity factor: C_max = capacity·strength·2πR³/3 m³ of sediment (003 Table 1 C_factor)",
              minimum=0.0, symbol="C_factor"),
    ParamSpec("initial_load", "1", 0.0,
              "load at emission as a fraction of C_max: adds matter by design (003 §5 Volcano: 0.1)",
              minimum=0.0, maximum=1.0),
    ParamSpec("k_eps", "Pa^-a", 2.5,
              "erodibility K_ε of a heightfield (003 Eq. 2, Table 1 ε); layered terrains use their "
              "materials' values", minimum=0.0, symbol="K_eps"),
    ParamSpec("tau_c", "Pa", 0.0, "critical shear stress τ_c of a heightfield (003 Eq. 2)", minimum=0.0),
    ParamSpec("erosion_exponent", "1", 1.0, "power-law exponent a of the erosion rate (003 Eq. 2)",
              minimum=0.0, symbol="a"),
    ParamSpec("shear_k", "Pa·s^0.5", 1.0, "shear stress constant K of τ = K(v_rel/l)^0.5 (003 Eq. 1)",
              minimum=0.0, symbol="K"),
    ParamSpec("shear_length", "m", 1.0, "distance l over which the shear rate v_rel/l is taken (003 Eq. 1)",
              minimum=0.0, symbol="l"),
    ParamSpec("omega", "s/m", 0.3,
              "deposition factor ω: ω·|w_s| half-spheres settle at an impact (003 Eq. 4, Table 1)",
              minimum=0.0),
    ParamSpec("hindered_exponent", "1", 5.0,
              "Richardson-Zaki exponent n of f(C) = 1 - (C/C_max)^n (003 Eq. 7: 5)", minimum=0.0),
    ParamSpec("strength", "1", 1.0,
              "volume scale of an impact: detachment, deposition and capacity are in units of "
              "strength·2πR³/3 (003 §3.3 'overall erosion strength'; 1 = Eq. 3 literally)", minimum=0.0),
    ParamSpec("rho_air", "kg/m³", 1.0, "density of the medium above sea level (003 §5: 1)", minimum=0.0),
    ParamSpec("rho_water", "kg/m³", 1000.0, "density of the medium below sea level (003 §5: 1000)",
              minimum=0.0),
    ParamSpec("mu_air", "Pa·s", MU_AIR, "effective viscosity of air in Stokes' law (003 Eq. 7)",
              minimum=0.0),
    ParamSpec("mu_water", "Pa·s", MU_AIR * WATER_AIR_VISCOSITY_RATIO,
              "effective viscosity of water in Stokes' law (003 Eq. 7)", minimum=0.0),
    ParamSpec("gravity", "m/s²", 9.81, "gravitational acceleration g (003 Eq. 5, 7)", minimum=0.0),
    ParamSpec("field_strength", "1", 1.0, "α, weight of the medium velocity field (003 Eq. 8)",
              minimum=0.0, maximum=1.0, symbol="alpha"),
    ParamSpec("dt", "s", 1.0,
              "largest time step; a step is shortened so that a particle moves at most half a cell "
              "and ends where it meets the ground", minimum=0.0),
    ParamSpec("lifetime", "s", 300.0, "a particle dies after this time and leaves its load where it is",
              minimum=0.0),
    ParamSpec("rest_speed", "m/s", 0.5,
              "a particle touching the ground slower than this has settled: it dies and deposits its load",
              minimum=0.0),
    ParamSpec("drop_height", "m", 10.0, "particles are emitted this high above the surface", minimum=0.0),
    ParamSpec("keep_suspended", "1", 0.0,
              "fraction of its load a dying particle keeps in suspension instead of depositing it: "
              "removes matter by design (003 §5-6 corrosion: coastal, karst)", minimum=0.0, maximum=1.0),
)
_SPECS = {spec.name: spec for spec in PARAMETERS}
#: Parameters that must be strictly positive (the specs hold the closed lower bound 0).
_POSITIVE = ("radius", "density", "shear_length", "mu_air", "mu_water", "dt", "lifetime")


@dataclass(frozen=True)
class ParticleParams:
    """Physical parameters of particle erosion (003 §3–4); all scalars, units in ``PARAMETERS``."""

    radius: float = _SPECS["radius"].default
    radius_max: float = _SPECS["radius_max"].default
    density: float = _SPECS["density"].default
    restitution: float = _SPECS["restitution"].default
    capacity: float = _SPECS["capacity"].default
    initial_load: float = _SPECS["initial_load"].default
    k_eps: float = _SPECS["k_eps"].default
    tau_c: float = _SPECS["tau_c"].default
    erosion_exponent: float = _SPECS["erosion_exponent"].default
    shear_k: float = _SPECS["shear_k"].default
    shear_length: float = _SPECS["shear_length"].default
    omega: float = _SPECS["omega"].default
    hindered_exponent: float = _SPECS["hindered_exponent"].default
    strength: float = _SPECS["strength"].default
    rho_air: float = _SPECS["rho_air"].default
    rho_water: float = _SPECS["rho_water"].default
    mu_air: float = _SPECS["mu_air"].default
    mu_water: float = _SPECS["mu_water"].default
    gravity: float = _SPECS["gravity"].default
    field_strength: float = _SPECS["field_strength"].default
    dt: float = _SPECS["dt"].default
    lifetime: float = _SPECS["lifetime"].default
    rest_speed: float = _SPECS["rest_speed"].default
    drop_height: float = _SPECS["drop_height"].default
    keep_suspended: float = _SPECS["keep_suspended"].default

    def validate(self, grid: Grid) -> None:
        """Raise ValueError (one sentence) for a value out of range or a raster given."""
        check_fields(self, PARAMETERS, grid)
        for name in _POSITIVE:
            if not getattr(self, name) > 0:
                value = getattr(self, name)
                raise ValueError(f"parameter {name} must be > 0 {_SPECS[name].unit}, got {value}")
        if 0 < self.radius_max < self.radius:
            raise ValueError(f"radius_max ({self.radius_max} m) must be 0 or ≥ radius ({self.radius} m)")


def param_names() -> tuple[str, ...]:
    """Names of the fields of ``ParticleParams``, in declaration order."""
    return tuple(f.name for f in fields(ParticleParams))
