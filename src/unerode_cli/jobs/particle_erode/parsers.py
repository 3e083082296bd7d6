"""The small languages of `particle-erode`'s option values, parsed in one place.

- ``--preset``: preset names of 003 Table 1 joined by ``+`` (``rain+wind+river``).
- ``--representation``, ``--emission``, ``--velocity-medium``, ``--apply``: one word of a list.
- ``--emission-velocity``: ``VE,VN[,VU]`` (m/s, east, north, up).
- ``--velocity`` (and a kinds file's ``velocity``): ``uniform:VE,VN[,VU]`` (m/s),
  ``sin[:AMPLITUDE,WAVELENGTH]`` (m/s, m) or the path of a 2/3-band raster.
- ``--source``: ``X,Y`` points in the DEM's CRS (repeated: the vertices of a line) or the path
  of one GeoJSON/WKT line file.

The :class:`~unerode_cli.run.values.OptionParser` classes refuse bad text while the command
line is parsed (exit code 2, the option named by the front door); the functions are used when
the job plans, where a value also comes from a preset or a kinds file, and raise ValueError
whose text begins with the option's name, a sentence without its final period.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from unerode_cli.particles.medium import MEDIA
from unerode_cli.particles.presets import REPRESENTATIONS, get_preset
from unerode_cli.particles.simulate import APPLY_MODES
from unerode_cli.run.values import OptionParser

#: ``--velocity sin`` without numbers: 1 m/s, and waves a quarter of the DEM's width long.
SIN_AMPLITUDE = 1.0
SIN_WAVES_PER_WIDTH = 4.0
EMISSIONS = ("rain", "source")


def _listed(words: Sequence[str]) -> str:
    """``a, b or c``."""
    return f"{', '.join(words[:-1])} or {words[-1]}" if len(words) > 1 else words[0]


def _numbers(text: str, counts: tuple[int, ...]) -> list[float] | None:
    """Comma-separated finite numbers, as many as one of ``counts``; None when not."""
    try:
        values = [float(part) for part in text.split(",")]
    except ValueError:
        return None
    if len(values) not in counts or not all(math.isfinite(v) for v in values):
        return None
    return values


def numbers(text: str, counts: tuple[int, ...], what: str) -> list[float]:
    """Comma-separated finite numbers, as many as one of ``counts``; ValueError naming
    ``what`` ("--source expects 2 comma-separated numbers, got '1'") when not."""
    values = _numbers(text, counts)
    if values is None:
        raise ValueError(f"{what} expects {' or '.join(map(str, counts))} comma-separated numbers, "
                         f"got '{text}'")
    return values


@dataclass(frozen=True)
class OneOf(OptionParser):
    """One word of ``words``: "must be rain or source, got 'hail'"."""

    words: tuple[str, ...]

    def parse(self, value: Any) -> str:
        text = str(value)
        if text not in self.words:
            raise ValueError(f"must be {_listed(self.words)}, got '{text}'")
        return text


@dataclass(frozen=True)
class Representation(OptionParser):
    """A terrain representation of 003 §4 (``particles.REPRESENTATIONS``)."""

    def parse(self, value: Any) -> str:
        text = str(value)
        if text not in REPRESENTATIONS:
            raise ValueError(f"unknown representation '{text}'; choose {_listed(REPRESENTATIONS)}")
        return text


@dataclass(frozen=True)
class PresetNames(OptionParser):
    """Preset names of ``particles.PRESETS`` joined by ``+``; the text is kept."""

    def parse(self, value: Any) -> str:
        text = str(value)
        for name in text.split("+"):
            get_preset(name)
        return text


@dataclass(frozen=True)
class Components(OptionParser):
    """A vector as ``counts`` comma-separated numbers (``unit`` in the message), e.g.
    ``VE,VN[,VU]`` in m/s. The text is kept (``vector`` gives the numbers); a sequence of
    numbers becomes its text."""

    counts: tuple[int, ...] = (2, 3)
    unit: str = "m/s"

    def parse(self, value: Any) -> str:
        text = ",".join(str(v) for v in value) if isinstance(value, list | tuple) else str(value)
        self.vector(text)
        return text

    def vector(self, text: str) -> tuple[float, ...]:
        """The numbers of ``text``; ValueError (end of a sentence) when they are not."""
        values = _numbers(text, self.counts)
        if values is None:
            raise ValueError(f"expects {' or '.join(map(str, self.counts))} comma-separated numbers "
                             f"({self.unit}), got '{text}'")
        return tuple(values)


PRESET = PresetNames()
REPRESENTATION = Representation()
EMISSION = OneOf(EMISSIONS)
MEDIUM = OneOf(tuple(MEDIA))
APPLY = OneOf(APPLY_MODES)
EMISSION_VELOCITY = Components((2, 3), "m/s")


def preset_names(text: str | None) -> list[str]:
    """The presets of ``--preset`` (default: rain)."""
    return (text or "rain").split("+")


def apply_mode(text: str) -> str:
    """``--apply``'s mode; ValueError "--apply must be per-iteration or per-impact, got '…'"."""
    try:
        return APPLY.parse(text)
    except ValueError as exc:
        raise ValueError(f"--apply {exc}") from None


def emission_velocity(text: str | None) -> tuple[float, float, float]:
    """(VE, VN, VU) m/s of ``--emission-velocity`` (VU 0 when two are given; none: at rest)."""
    if text is None:
        return (0.0, 0.0, 0.0)
    return tuple([*EMISSION_VELOCITY.vector(EMISSION_VELOCITY.parse(text)), 0.0][:3])  # type: ignore[return-value]


@dataclass(frozen=True)
class VelocityText:
    """``--velocity``'s words: ``kind`` uniform (``numbers`` VE, VN[, VU] m/s), sin
    (``numbers`` AMPLITUDE m/s, WAVELENGTH m; empty for the defaults) or raster (``path``)."""

    kind: str
    numbers: tuple[float, ...] = ()
    path: Path | None = None


def velocity(text: str) -> VelocityText:
    """The medium velocity field described by ``text`` (see the module docstring)."""
    kind, _, given = text.partition(":")
    if kind == "uniform":
        return VelocityText("uniform", tuple(numbers(given, (2, 3), "--velocity uniform:")))
    if kind == "sin":
        return VelocityText("sin", tuple(numbers(given, (2,), "--velocity sin:")) if given else ())
    return VelocityText("raster", path=Path(text))


def sin_defaults(width_m: float) -> tuple[float, float]:
    """``--velocity sin``'s amplitude (m/s) and wavelength (m) on a DEM ``width_m`` wide."""
    return SIN_AMPLITUDE, width_m / SIN_WAVES_PER_WIDTH


def source_file(sources: Sequence[str]) -> Path | None:
    """The line file ``--source`` names (one value without a comma), else None."""
    if len(sources) == 1 and "," not in sources[0]:
        return Path(sources[0])
    return None


def check_sources(sources: Sequence[str]) -> None:
    """``--source``: X,Y points (repeated for a line) or one line file that exists."""
    path = source_file(sources)
    if path is not None and not path.is_file():
        raise ValueError(f"--source takes X,Y points in the DEM's CRS (repeat it for a line) or a "
                         f"GeoJSON/WKT line file, and '{sources[0]}' is neither")


def source_xy(sources: Sequence[str]) -> tuple[list[float], list[float]]:
    """Map coordinates (x, y) of ``--source X,Y`` points."""
    xy = [numbers(text, (2,), "--source") for text in sources]
    return [p[0] for p in xy], [p[1] for p in xy]


def material_names(text: str) -> list[str]:
    """``--layer-materials``: material names, comma-separated."""
    return [name.strip() for name in text.split(",")]

