"""Presets of particle erosion from 003 Table 1 and §5, every value overridable. No numba here.

Table 1 gives R in cells or voxels (turned into metres with the grid's cell or voxel size
here), the coefficient of restitution, ρ_p, the capacity factor, the erosion factor ε (K_ε
here) and the deposition factor ω, particles per iteration and iterations, and the terrain
representation. It gives no absolute volume scale, so the presets set ``strength`` = 0.01: a
rain particle (R = 1 cell) then carries at most 10 × 0.01 × 2π/3 ≈ 0.2 cell volumes (cell
size³). Departures from the table are said in each preset's note. The values hold on cells of
``REFERENCE_CELL``; on other cells the presets are scaled by Froude similarity (``SIMILARITY``),
so that a preset does on 1 m voxels (003's Tunnel) what it does on 20 m cells. Values given as
overrides, and medium velocity fields, are taken as they are.

Representations: ``representation`` is what a preset runs on by default. The presets that
also work on heightfields keep them as default (coastal, wind and volcano ran on density voxels
in 003: ``paper_representation``); karst and tunnel, whose caves only a 3D terrain holds, run
on binary and density voxels, and meanders on an implicit terrain (sdf), as in 003.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

from unerode_cli.particles.parameters import ParticleParams, param_names

#: Volume scale of the presets (see the module docstring).
PRESET_STRENGTH = 0.01
#: Volume scale of the karst preset: each particle dissolves at most 10 × 5e-4 × 2π/3 × 5³ ≈ 1.3
#: voxels, so Table 1's 40 000 particles take at most a tenth of its 100 × 100 × 50 block.
KARST_STRENGTH = 5e-4
#: Cell size (m) at which the presets' values hold as written (``parameters``' defaults were
#: set for a rain particle of R = 20 m).
REFERENCE_CELL = 20.0
#: Froude similarity: on cells of size s·REFERENCE_CELL a preset's lengths scale by s, its
#: times and speeds by √s (gravity unchanged), so particles trace the same paths in cells and
#: impacts move the same fractions of V½: each parameter is multiplied by s to this power.
#: Stokes' τ_s = 2ρR²/9μ ∝ √s needs μ ∝ s^1.5; τ = K(v/l)^½ stays with l ∝ s and K ∝ s^¼;
#: deposition ω|w_s| with ω ∝ s^-½.
SIMILARITY = MappingProxyType({"mu_air": 1.5, "mu_water": 1.5, "dt": 0.5, "lifetime": 0.5, "rest_speed": 0.5,
                               "drop_height": 1.0, "shear_length": 1.0, "shear_k": 0.25, "omega": -0.5})
#: Terrain representations: the 2.5D ones, and the voxel ones (003 §4.4).
SURFACE_REPRESENTATIONS = ("heightfield", "layers")
VOXEL_REPRESENTATIONS = ("density", "binary")
#: Implicit terrains (003 §4.3): a signed distance function altered by metaballs.
IMPLICIT_REPRESENTATIONS = ("sdf",)
REPRESENTATIONS = SURFACE_REPRESENTATIONS + VOXEL_REPRESENTATIONS + IMPLICIT_REPRESENTATIONS


@dataclass(frozen=True)
class Preset:
    """A named set of parameters of 003 Table 1.

    Attributes:
        name: preset name.
        help: one line for the command line's help.
        radius_cells: particle radius R in cells (Table 1); ``radius_max_cells`` > 0 draws R
            uniformly between the two.
        particles: particles per iteration (Table 1 #P).
        iterations: iterations (Table 1 #N).
        emission: ``"rain"`` or ``"source"``.
        field: the medium velocity field the preset expects (the user provides it), or "none".
        field_medium: where that field acts: "both", "air" or "water".
        values: other ``ParticleParams`` fields.
        note: departures from 003 and what the user must supply.
        rain_below_sea: rain emission starts over the cells whose ground is below the sea level
            (the sea, or groundwater under a water table) unless a rain mask is given.
        representation: the terrain it runs on by default: "heightfield", "density", "binary" or
            "sdf".
        paper_representation: the one of 003 Table 1 ("heightfield", "density", "binary" or
            "implicit").
        velocity: the medium velocity field it uses when the user gives none, in the words of
            ``particle-erode --velocity`` ("sin": the meander field of 003 Table 1); "" = none.
    """

    name: str
    help: str
    radius_cells: float
    particles: int
    iterations: int
    emission: str
    values: Mapping[str, float]
    radius_max_cells: float = 0.0
    field: str = "none"
    field_medium: str = "both"
    note: str = ""
    rain_below_sea: bool = False
    representation: str = "heightfield"
    paper_representation: str = "heightfield"
    velocity: str = ""

    def params(self, cell_size: float, **overrides: float) -> ParticleParams:
        """``ParticleParams`` of this preset on cells of ``cell_size`` (m): R in cells, the
        ``SIMILARITY`` parameters scaled from ``REFERENCE_CELL``; ``overrides`` (``ParticleParams``
        field names, SI units; ``radius`` in metres) replace values."""
        if not cell_size > 0:
            raise ValueError(f"the cell size must be > 0 m, got {cell_size}")
        unknown = sorted(set(overrides) - set(param_names()))
        if unknown:
            raise ValueError(f"unknown particle parameter(s) {', '.join(unknown)}; "
                             f"known: {', '.join(param_names())}")
        values = {"radius": self.radius_cells * cell_size, "radius_max": self.radius_max_cells * cell_size,
                  "strength": PRESET_STRENGTH, **self.values}
        scale = cell_size / REFERENCE_CELL
        defaults = ParticleParams()
        for name, exponent in SIMILARITY.items():
            values[name] = values.get(name, getattr(defaults, name)) * scale**exponent
        values.update(overrides)
        return ParticleParams(**values)


def _table(**values: float) -> Mapping[str, float]:
    return MappingProxyType(values)


PRESETS: Mapping[str, Preset] = MappingProxyType({p.name: p for p in (
    Preset("rain", "hydraulic erosion by rain drops falling everywhere (003 Table 1 Rain, Fig. 14)",
           1.0, 100, 10, "rain",
           _table(restitution=1.0, density=1000.0, capacity=10.0, k_eps=2.5, omega=0.3)),
    Preset("meanders", "a river pushed sideways by a procedural velocity field: meanders on an implicit "
           "terrain (003 Table 1 Meanders)",
           5.0, 10, 20, "source",
           _table(restitution=1.0, density=1000.0, capacity=1.0, k_eps=1.0, omega=1.0),
           field="sin: northward amplitude·sin(2πx/wavelength) (003: v_f = [0 sin(p.x) 0])",
           representation="sdf", paper_representation="implicit", velocity="sin",
           note="give the source upstream (default: the highest cell) on a valley that drains east or west, "
                "across the field's waves"),
    Preset("river", "a river from a source point, particles of 1.5-5 cells (003 Table 1 River)",
           1.5, 100, 50, "source",
           _table(restitution=0.5, density=900.0, capacity=0.1, k_eps=1.0, omega=1.0),
           radius_max_cells=5.0, note="give the source point"),
    Preset("landslide", "big slow particles that spread matter down a slope (003 Table 1 Landslide)",
           2.5, 200, 10, "rain",
           _table(restitution=0.2, density=500.0, capacity=0.1, k_eps=1.0, omega=1.0),
           note="mask the rain to the slope that slides"),
    Preset("coastal", "waves corroding a coast: big particles pushed towards it (003 Table 1 Coastal)",
           5.0, 80, 3, "rain",
           _table(restitution=0.1, density=500.0, capacity=10.0, k_eps=5.0, omega=0.5, keep_suspended=1.0),
           field="uniform, towards the coast", field_medium="water", rain_below_sea=True,
           paper_representation="density",
           note="give a sea level (particles start over the cells below it unless --rain-mask says "
                "otherwise); dissolved matter stays suspended (removed by design: 003 §5 corrosion "
                "without mass conservation); overhangs need --representation density (003's)"),
    Preset("wind", "light particles carried by the wind, dunes and rock blasting (003 Table 1 Wind)",
           1.5, 100, 10, "rain",
           _table(restitution=0.9, density=1.5, capacity=1.0, k_eps=1.0, omega=1.0, drop_height=1.0),
           field="wind (uniform or a raster)", field_medium="air", paper_representation="density",
           note="particles start a twentieth of a cell above the ground (they are blown, not dropped); "
                "003 weathered "
                "rock columns on density voxels (--representation density, 0.2 m voxels)"),
    Preset("underwater", "currents eroding a sea floor (003 Table 1 Underwater)",
           2.5, 100, 50, "rain",
           _table(restitution=0.9, density=1000.0, capacity=1.0, k_eps=1.0, omega=1.0),
           field="currents (a raster from a fluid simulation)", field_medium="water",
           note="give a sea level above the floor"),
    Preset("volcano", "a vent emitting loaded particles: the terrain gains mass (003 Table 1 Volcano)",
           1.0, 150, 30, "source",
           _table(restitution=0.5, density=2000.0, capacity=1.0, k_eps=1.0, omega=5.0, initial_load=0.1),
           paper_representation="density",
           note="give the vent; particles start loaded at 10 % of C_max (003 §5), "
                "added matter is the budget's 'emitted'; Table 1 prints COR = 5.0, which would create "
                "energy at every bounce: read as 0.5"),
    Preset("karst", "water dissolving a cave network that follows the softest layer (003 Table 1 Karst)",
           5.0, 1000, 40, "rain",
           _table(restitution=0.5, density=500.0, capacity=10.0, k_eps=5.0, omega=0.5, keep_suspended=1.0,
                  strength=KARST_STRENGTH),
           field="uniform, along the water table", field_medium="water", rain_below_sea=True,
           representation="binary", paper_representation="binary",
           note="give the water table as --sea-level and 3D layers (--materials); particles lighter than "
                "water float along it into the rock, dissolving more of the softer voxels; dissolved matter "
                "stays suspended (removed by design, 003 §5); strength 5e-4, not 0.01: at 0.01 Table 1's "
                "40 000 particles of 5 voxels would each dissolve 26 voxels, twice the whole block"),
    Preset("tunnel", "runoff from a source drilling a tunnel through rock (003 Table 1 Tunnel)",
           2.5, 100, 100, "source",
           _table(restitution=0.1, density=500.0, capacity=1.0, k_eps=1.0, omega=1.0, keep_suspended=1.0),
           representation="density", paper_representation="density",
           note="give the source; the runoff carries what it dissolves away (kept suspended: 003 gives "
                "no place where it settles), so a pit grows where the particles first land: put the source "
                "before a rock face and give --emission-velocity towards it to drill into the face"),
)})


def get_preset(name: str) -> Preset:
    """The preset called ``name``; ValueError (one sentence) when there is none."""
    try:
        return PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown particle preset {name!r}; known presets: {', '.join(PRESETS)}") from None


def preset_params(name: str, cell_size: float, **overrides: float) -> ParticleParams:
    """``ParticleParams`` of preset ``name`` on cells of ``cell_size`` (m), with ``overrides``."""
    return get_preset(name).params(cell_size, **overrides)
