"""`unerode-cli diff A B OUT`: the difference B − A of two DEMs and its RMSE."""

from __future__ import annotations

from unerode_cli.cli.declared import command
from unerode_cli.jobs.diff.options import OPTIONS

diff = command("unerode_cli.jobs.diff.job:DiffJob",
               "Difference of two DEMs; prints cells compared, RMSE, mean (bias), mean absolute, min, max "
               "(m) and the correlation of A and B, also kept in the JSON sidecar.", options=OPTIONS)
