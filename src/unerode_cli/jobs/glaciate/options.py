"""Options of `glaciate` (declared once: CLI, pipeline, Python API, provenance): those of a
glacier run, which ``climate-run --process glacial`` shares (``run.glacial.options``)."""

from __future__ import annotations

from unerode_cli.run.glacial.options import OPTIONS

__all__ = ["OPTIONS"]
