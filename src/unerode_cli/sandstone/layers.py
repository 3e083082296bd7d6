"""Sediment layers and the rock's general parameters (002 §3.3, Tables 1–2).

A scene stacks layers by altitude, each with its own erodibilities and stress threshold; deposits
form one more layer. This module does not import numba, so the command line shows its help fast.

Units (SI; times in years): erodibilities k_w, k_s in 1/y (002 Eq. 1–2: b drops by E·(W + F)·Δt,
so W and F are dimensionless rates); the interlocking threshold I in Pa, compared with the
compressive stress −tr σ (compression positive; 002 Eq. 2 writes trace(σ) > I, which only makes
sense with compression counted positive); the abrasion coefficient k_a in s²/m² (W_a = k_a‖v‖(−n·v)₊,
002 Eq. 8, dimensionless); the deflation coefficient k_d dimensionless (002 Eq. 12); the fluvial
coefficient k_t in 1/Pa and the critical shear stress τ_c in Pa (002 Eq. 14, Table 1, used as
printed: ``fluvial`` says why).

002 Table 1 gives k_a and k_d both in m⁻²s⁻², which cannot both be right (Eq. 8 and Eq. 12 then
have different dimensions), and with Table 2's k_w = 1e-4 /y and Δt = 1000 y its values would
erode a windward face by one particle in about 4000 frames, and deflation 5000 times more slowly
than abrasion in a 10 m/s wind, though 002 Fig. 15 shows deflation alone opening the arch. The
presets keep Table 1's spread between layers (a factor 10 from the weakest to the strongest)
and scale k_a by :data:`ABRASION_SCALE` and k_d by :data:`DEFLATION_SCALE`, so that with
Table 2's k_w and Δt a weak face retreats about one particle spacing every ten frames under a
10 m/s wind face-on (W_a ≈ 1) or under deflation alone (W_d ≈ 0.6).

002 Table 2 swaps the labels of the Lamé parameters: μ is the shear modulus (15 GPa) and λ the
first Lamé parameter (12 GPa), i.e. E ≈ 36.7 GPa and ν ≈ 0.22, usual values for a sandstone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from unerode_cli.processes.parameters import ParamSpec

#: Factors from 002 Table 1's k_a and k_d to rates that erode in tens of frames (see above).
ABRASION_SCALE = 400.0
DEFLATION_SCALE = 2e6
#: Gravitational acceleration (m/s²).
GRAVITY = 9.81


@dataclass(frozen=True)
class Layer:
    """One sediment layer, from the top of the layer below up to ``top`` (m; ∞ for the last).

    Attributes (units): ``k_w``, ``k_s`` weak and interlocked erodibility (1/y, 002 Eq. 2);
    ``interlocking`` the threshold I on −tr σ (Pa); ``k_a`` abrasion (s²/m², 002 Eq. 8);
    ``k_d`` deflation (dimensionless, 002 Eq. 12); ``k_t`` fluvial erosion (1/Pa, 002 Eq. 14; 0:
    water does not erode the layer) and ``tau_c`` its critical shear stress (Pa).
    """

    top: float = math.inf
    k_w: float = 1e-4
    k_s: float = 1e-6
    interlocking: float = 3e6
    k_a: float = 1e-5 * ABRASION_SCALE
    k_d: float = 1e-7 * DEFLATION_SCALE
    k_t: float = 0.0
    tau_c: float = 5.0
    name: str = ""


@dataclass(frozen=True)
class Rock:
    """The rock's general parameters (002 Table 2 and §4).

    Attributes (units): ``shear_modulus`` μ (Pa), ``lame_lambda`` λ (Pa), ``density`` ρ (kg/m³),
    ``cohesion`` μ_c (Pa, 002 Eq. 9), ``friction`` μ_f (dimensionless, Eq. 9),
    ``deposit_viability`` b of new deposits (002 Table 1, §8.4).
    """

    shear_modulus: float = 15e9
    lame_lambda: float = 12e9
    density: float = 2300.0
    cohesion: float = 1e6
    friction: float = 0.75
    deposit_viability: float = 0.0

    @property
    def poisson_ratio(self) -> float:
        return self.lame_lambda / (2.0 * (self.lame_lambda + self.shear_modulus))

    @property
    def young_modulus(self) -> float:
        mu, lam = self.shear_modulus, self.lame_lambda
        return mu * (3.0 * lam + 2.0 * mu) / (lam + mu)

    @property
    def p_wave_speed(self) -> float:
        """Speed of compression waves sqrt((λ + 2μ)/ρ) (m/s): what limits the MPM time step."""
        return math.sqrt((self.lame_lambda + 2.0 * self.shear_modulus) / self.density)


@dataclass(frozen=True)
class LayerStack:
    """Layers bottom first (tops strictly increasing, the last one's top ∞) and the deposit
    layer, whose index is ``len(layers)``."""

    layers: tuple[Layer, ...]
    deposit: Layer = field(default_factory=Layer)

    def __post_init__(self) -> None:
        if not self.layers:
            raise ValueError("a scene needs at least one layer")
        tops = [layer.top for layer in self.layers]
        if any(b <= a for a, b in zip(tops, tops[1:], strict=False)):
            raise ValueError(f"layer tops must increase from the bottom layer up, got {tops}")
        if math.isfinite(tops[-1]):
            object.__setattr__(self, "layers", (*self.layers[:-1], replace(self.layers[-1], top=math.inf)))

    @property
    def deposit_index(self) -> int:
        return len(self.layers)

    def index_of(self, z: np.ndarray) -> np.ndarray:
        """Layer index (int32) of each altitude ``z`` (m): the first layer whose top is above it."""
        tops = np.array([layer.top for layer in self.layers[:-1]])
        return np.searchsorted(tops, np.asarray(z), side="right").astype(np.int32)

    def table(self, name: str) -> np.ndarray:
        """The value of attribute ``name`` of every layer, the deposit layer last (float64)."""
        return np.array([getattr(layer, name) for layer in (*self.layers, self.deposit)], dtype=np.float64)

    def with_values(self, **values: float) -> LayerStack:
        """Every layer (deposits included) with the given attributes replaced."""
        return LayerStack(tuple(replace(layer, **values) for layer in self.layers),
                          replace(self.deposit, **values))


#: Per-layer parameters given on the command line replace that value in every layer.
LAYER_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("k_w", "1/y", Layer.k_w, "erodibility of weak rock k_w (002 Eq. 2, Table 2); replaces "
              "every layer's", minimum=0.0),
    ParamSpec("k_s", "1/y", Layer.k_s, "erodibility of interlocked rock k_s (002 Eq. 2, Table 2); replaces "
              "every layer's", minimum=0.0),
    ParamSpec("interlocking", "Pa", Layer.interlocking, "fabric interlocking threshold I on the "
              "compressive stress -tr σ (002 Eq. 2, Table 1: 1.5e6-6e6); replaces every layer's",
              minimum=0.0, symbol="I"),
    ParamSpec("k_a", "s²/m²", Layer.k_a, "wind abrasion coefficient k_a (002 Eq. 8; Table 1 × "
              f"{ABRASION_SCALE:g}); replaces every layer's", minimum=0.0),
    ParamSpec("k_d", "1", Layer.k_d, "wind deflation coefficient k_d (002 Eq. 12; Table 1 × "
              f"{DEFLATION_SCALE:g}); replaces every layer's", minimum=0.0),
    ParamSpec("k_t", "1/Pa", Layer.k_t, "fluvial erosion coefficient k_t (002 Eq. 14, Table 1: 1e2-8e2; "
              "0: no fluvial erosion); replaces every layer's", minimum=0.0),
    ParamSpec("tau_c", "Pa", Layer.tau_c, "critical shear stress τ_c of fluvial erosion (002 Eq. 14, "
              "Table 1: 1-5); replaces every layer's", minimum=0.0),
)

#: The rock's general parameters on the command line.
ROCK_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("shear_modulus", "Pa", Rock.shear_modulus, "shear modulus μ (002 Table 2, whose labels "
              "of μ and λ are swapped)", minimum=1.0, symbol="mu"),
    ParamSpec("lame_lambda", "Pa", Rock.lame_lambda, "first Lamé parameter λ (002 Table 2)", minimum=0.0,
              symbol="lambda"),
    ParamSpec("density", "kg/m³", Rock.density, "rock density ρ (002 Eq. 4)", minimum=1.0, symbol="rho"),
    ParamSpec("cohesion", "Pa", Rock.cohesion, "internal cohesion μ_c (002 Eq. 9, Table 2)", minimum=0.0,
              symbol="mu_c"),
    ParamSpec("friction", "1", Rock.friction, "dry friction μ_f (002 Eq. 9, Table 2)", minimum=0.0,
              symbol="mu_f"),
    ParamSpec("deposit_viability", "1", Rock.deposit_viability, "viability b of new deposits (002 Table 1, "
              "§8.4)", minimum=0.0, maximum=1.0),
)
