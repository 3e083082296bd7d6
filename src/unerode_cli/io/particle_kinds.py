"""Particle kinds files (``particle-erode --kinds KINDS.yaml``, 003 Fig. 8: several phenomena in
one run), validated by pydantic, errors in one sentence naming the file::

    iterations: 20                 # optional; default: the largest of the kinds' presets'
    kinds:                         # traced in this order every iteration
      - preset: rain
        particles: 400             # per iteration; default: --particles, else the preset's
        parameters: {k_eps: 1.5}   # particle parameters (SI units, the --help names with _)
      - preset: wind
        velocity: uniform:8,0      # as --velocity; default: --velocity, else the preset's
      - preset: river

Each kind takes its preset's values, then its ``parameters``, then the particle parameters
given on the command line (which apply to every kind).
"""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from unerode_cli.errors import InputError
from unerode_cli.io.yaml_files import read_yaml_mapping
from unerode_cli.particles.parameters import param_names
from unerode_cli.particles.presets import PRESETS
from unerode_cli.sandstone.scene import describe


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class KindSpec(_Strict):
    """One kind of particles: its preset, particles per iteration, medium velocity (the text of
    ``--velocity``) and parameter values (``ParticleParams`` names, SI units)."""

    preset: str
    particles: int | None = Field(None, ge=1)
    velocity: str | None = None
    parameters: dict[str, float] = Field(default_factory=dict)

    @field_validator("preset")
    @classmethod
    def _known_preset(cls, name: str) -> str:
        if name not in PRESETS:
            raise ValueError(f"unknown preset '{name}' (known: {', '.join(PRESETS)})")
        return name

    @field_validator("parameters")
    @classmethod
    def _known_parameters(cls, values: dict[str, float]) -> dict[str, float]:
        unknown = sorted(set(values) - set(param_names()))
        if unknown:
            raise ValueError(f"unknown particle parameter(s) {', '.join(unknown)}")
        return values


class KindsSpec(_Strict):
    """The kinds of a run, in order, and optionally its iterations."""

    kinds: list[KindSpec] = Field(min_length=1)
    iterations: int | None = Field(None, ge=1)


def read_particle_kinds(path: Path) -> KindsSpec:
    """The particle kinds of a YAML file (module docstring).

    Raises:
        InputError: one sentence naming the file: unreadable, not YAML, an unknown key, preset
            or parameter, a count below 1.
    """
    document = read_yaml_mapping(path, "the particle kinds file", "a mapping with 'kinds'", allow_empty=False)
    try:
        return KindsSpec.model_validate(document)
    except ValidationError as exc:
        raise InputError(f"the particle kinds file {path} is invalid: {describe(exc).rstrip('.')}.") from None
