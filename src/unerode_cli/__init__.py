"""unerode-cli: erode terrains forward in time and unerode them backward.

The Python API (:mod:`unerode_cli.api`) is available at the top level, loaded on first use so
that the command line starts fast::

    import unerode_cli
    dem = unerode_cli.read("dem.tif")
    past = unerode_cli.unerode(dem, dt=500, steps=20, K=2e-5)
"""

from unerode_cli import kernel_cache

__version__ = "0.1.0"

#: Names of :mod:`unerode_cli.api` offered here.
API = ("read", "write", "flow", "erode", "unerode", "climate_run", "glaciate", "particle_erode",
       "sandstone", "Terrain", "InputError")

kernel_cache.refresh()


def __getattr__(name: str):
    """The API's names, imported on first use (the package itself stays light)."""
    if name in API:
        import importlib

        return getattr(importlib.import_module("unerode_cli.api"), name)
    raise AttributeError(f"module 'unerode_cli' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *API])
