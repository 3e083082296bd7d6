"""`unerode-cli synth OUT`: reproducible synthetic DEMs with a CRS."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.synth.options import OPTIONS

synth = command("unerode_cli.jobs.synth.job:SynthJob",
                "Generate a synthetic DEM (the same seed gives the same terrain).", options=OPTIONS)
