"""`unerode-cli preview DEM OUT.png`: hillshade blended with an elevation colour ramp."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.preview.options import OPTIONS

preview = command("unerode_cli.jobs.preview.job:PreviewJob",
                  "Write a PNG: hillshade on a colour ramp of the values, colour bar in metres (``--label``).",
                  options=OPTIONS)
