"""Registry of surface processes the runner can drive, each bound to a terrain's grid and
boundaries. A process's parameter declarations (``PARAMETERS``) feed CLI options, validation
and provenance."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.pipeline.boundaries import Boundaries
from unerode_cli.pipeline.runner import Change, Process
from unerode_cli.processes import fluvial
from unerode_cli.processes.parameters import ParamSpec
from unerode_cli.raster.terrain import Terrain


@dataclass
class FluvialProcess:
    """Fluvial erosion/deposition (000 §3) with routing recomputed on each new surface."""

    terrain: Terrain
    boundaries: Boundaries
    params: fluvial.FluvialParams
    scheme: str = "limiter"
    method: str = "mfd"
    name: str = "fluvial"
    _cached: tuple[np.ndarray, Any] | None = field(default=None, repr=False)

    def _routing(self, h: np.ndarray) -> Any:
        from unerode_cli.hydro import route

        if self._cached is not None and np.array_equal(self._cached[0], h):
            return self._cached[1]
        outlets = self.boundaries.outlets(h, self.terrain)
        routing = route(h, self.terrain.grid, outlets, self.method)
        self._cached = (h.copy(), routing)
        return routing

    def stable_dt(self, elevation: np.ndarray) -> float:
        return fluvial.max_stable_dt(elevation, self.terrain.grid, self.params,
                                     self._routing(elevation))

    def advance(self, elevation: np.ndarray, dt: float) -> Change:
        routing = self._routing(elevation)
        change = fluvial.step(elevation, self.terrain.grid, routing.outlets, self.params, dt,
                              routing=routing, scheme=self.scheme)
        b = change.budget
        return Change(change.dh, b.eroded, b.deposited, b.outflux)


@dataclass(frozen=True)
class Registered:
    """A process the command line offers: its parameters, how to build it, and whether it can
    run backward in time (and, if not, why)."""

    parameters: tuple[ParamSpec, ...]
    build: Callable[..., Process]
    backward_refusal: str | None = None


def _build_fluvial(terrain: Terrain, boundaries: Boundaries, values: dict[str, Any],
                   options: dict[str, Any]) -> Process:
    params = fluvial.FluvialParams(**{s.name: values[s.name] for s in fluvial.PARAMETERS})
    return FluvialProcess(terrain, boundaries, params, options.get("scheme", "limiter"),
                          options.get("method", "mfd"))


REGISTRY: dict[str, Registered] = {
    "fluvial": Registered(fluvial.PARAMETERS, _build_fluvial),
}


def parse_process_list(text: str, backward: bool) -> list[str]:
    """``"fluvial,thermal"`` → names, checked against the registry (and the direction)."""
    names = [n.strip().lower() for n in text.split(",") if n.strip()]
    if not names:
        raise InputError("--process needs at least one process name.")
    for name in names:
        if name not in REGISTRY:
            raise InputError(f"unknown process '{name}'; choose from {', '.join(REGISTRY)}.")
        refusal = REGISTRY[name].backward_refusal
        if backward and refusal:
            raise InputError(refusal)
    return names
