"""A tiny ensemble case for the tests: a 32 × 32 crop (240 m cells) of the sample valley,
climate-run back 20 ka in four 5 ka steps, then compare-terraces against two made-up terraces
(at 10 and 20 ka)."""

from __future__ import annotations

from pathlib import Path

import rasterio
from tests.conftest import SAMPLE_DEMS, SHARED_DATA, write_geotiff

SEA_LEVELS = {"spratt": SHARED_DATA / "sealevel" / "spratt2016.txt",
              "bintanja": SHARED_DATA / "sealevel" / "bintanja_vandewal2008_3Myr.csv"}
needs_data = all(p.is_file() for p in (SHARED_DATA / "lr04" / "LR04stack.txt", *SEA_LEVELS.values()))

STEPS = """\
steps:
  - name: past
    run: climate-run
    args: [dem.tif, past.tif]
    options:
      chronology: "${data}/lr04/LR04stack.txt"
      to: 20
      dt: 5000
      snapshots: "10"
      process: thermal,fluvial
      downstream-below: 100
    outputs: [past_10ka.tif]
  - name: compare
    run: compare-terraces
    options:
      present: dem.tif
      snapshots: [past_10ka.tif, past.tif]
      observations: terraces.csv
      auto-river: true
      sea-level: 0
      out: report
"""


def small_dem(path: Path) -> Path:
    """Every 8th cell of the 256² sample valley: 32 × 32 cells of 240 m."""
    with rasterio.open(SAMPLE_DEMS / "valley_utm32n_30m.tif") as src:
        data = src.read(1)[::8, ::8].copy()
        transform = src.transform @ src.transform.scale(8, 8)
        crs = src.crs.to_string()
    return write_geotiff(path, data, transform=transform, crs=crs)


def write_case(folder: Path, sweep: str, name: str = "spec.yaml") -> Path:
    """The DEM, the terraces and an ensemble spec with the ``sweep`` block (YAML text) in
    ``folder``; returns the spec's path."""
    folder.mkdir(parents=True, exist_ok=True)
    if not (folder / "dem.tif").exists():
        small_dem(folder / "dem.tif")
    (folder / "terraces.csv").write_text("name,age_ka,height_above_river_m\nyoung,10,3\nold,20,8\n")
    spec = folder / name
    spec.write_text(f"version: 1\nvars:\n  data: {SHARED_DATA}\n{STEPS}sweep:\n{sweep}")
    return spec
