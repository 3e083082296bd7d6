"""unerode-cli: erode terrains forward in time and unerode them backward."""

__version__ = "0.1.0"
