"""The display options every command takes besides its job's declared options: ``-v`` and ``-q``
(counted; their difference is the verbosity, see :mod:`unerode_cli.cli.common`). The help shows
them as counters (``-v``, ``-vv``), without a value placeholder or a default."""

from __future__ import annotations

from typing import Annotated

import typer

Verbose = Annotated[int, typer.Option("--verbose", "-v", count=True, metavar="", show_default=False, help="Repeatable: -v one line per step and the traceback of an error; -vv also each step's wall time (debug).")]
Quiet = Annotated[int, typer.Option("--quiet", "-q", count=True, metavar="", show_default=False, help="Repeatable: -q no notes (summaries and errors remain); -qq errors only.")]
