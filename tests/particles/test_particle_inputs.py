"""Presets of 003 Table 1 and refusals of bad input (one sentence, ValueError)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.particles import (
    PRESETS,
    Emission,
    HeightfieldTerrain,
    ParticleParams,
    VelocityField,
    get_preset,
    preset_params,
    run,
)

GRID = Grid.full((8, 8), 10.0)
FLAT = HeightfieldTerrain(np.zeros((8, 8)), GRID)


def test_presets_read_table_1_and_take_overrides():
    # 003 Table 1's rows (karst, tunnel and meanders among them)
    assert set(PRESETS) == {"rain", "river", "landslide", "coastal", "wind", "underwater", "volcano",
                            "meanders", "karst", "tunnel"}
    rain = preset_params("rain", 20.0)
    assert (rain.radius, rain.restitution, rain.density, rain.capacity, rain.k_eps, rain.omega) == (
        20.0, 1.0, 1000.0, 10.0, 2.5, 0.3)
    river = preset_params("river", 5.0, omega=0.5)
    assert (river.radius, river.radius_max, river.omega) == (7.5, 25.0, 0.5)
    for preset in PRESETS.values():
        assert preset.help and "\n" not in preset.help
        preset.params(10.0).validate(GRID)


def test_unknown_preset_or_parameter_is_refused():
    with pytest.raises(ValueError, match="unknown particle preset 'drizzle'; known presets: rain"):
        get_preset("drizzle")
    with pytest.raises(ValueError, match="unknown particle parameter"):
        preset_params("rain", 10.0, viscosity=3.0)


@pytest.mark.parametrize("values, message", [
    ({"radius": -1.0}, "radius must be ≥ 0"),
    ({"radius": 0.0}, "radius must be > 0"),
    ({"restitution": 1.5}, "restitution must be ≤ 1"),
    ({"radius": 5.0, "radius_max": 2.0}, "radius_max"),
])
def test_bad_parameters_are_refused(values, message):
    with pytest.raises(ValueError, match=message):
        run(FLAT, ParticleParams(**values), Emission.rain(1))


def test_bad_velocity_field_or_emission_is_refused():
    with pytest.raises(ValueError, match="velocity raster must have shape"):
        run(FLAT, ParticleParams(), Emission.rain(1), velocity=VelocityField.raster(np.zeros((2, 8, 7))))
    with pytest.raises(ValueError, match="rain mask has shape"):
        run(FLAT, ParticleParams(), Emission.rain(1, mask=np.ones((4, 4))))
    with pytest.raises(ValueError, match="source points must lie on the grid"):
        run(FLAT, ParticleParams(), Emission.source(1, (20.0, 3.0)))
    with pytest.raises(ValueError, match="seed"):
        run(FLAT, ParticleParams(), Emission.rain(1), seed=-1)


def test_declarations_do_not_load_numba():
    code = ("import sys, unerode_cli.particles, unerode_cli.particles.presets; "
            "print('numba' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
