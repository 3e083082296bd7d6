"""Options of `info` (declared once: CLI, pipeline, Python API)."""

from __future__ import annotations

from unerode_cli.run.common_options import READING, SOURCE, renamed
from unerode_cli.run.declare import Opt

OPTIONS = (
    renamed(SOURCE, "dem"),
    Opt("as_json", bool, False, "Print JSON instead of text.", flags=("--json",), kind="flag", record=False),
    *READING,
)
