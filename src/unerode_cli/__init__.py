"""unerode-cli: erode terrains forward in time and unerode them backward."""

from unerode_cli import kernel_cache

__version__ = "0.1.0"

kernel_cache.refresh()
