"""A GDAL virtual raster (.vrt) as input: read as its source would be, its source files never
overwritten (they are inputs too), a VRT whose source is missing refused before any work."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import rasterio
from tests.cli.test_bad_input import assert_refused
from tests.conftest import run_cli, write_geotiff

from unerode_cli.synthetic import synthesize


def write_vrt(path: Path, source: str, shape: tuple[int, int], like: Path) -> Path:
    """A one-band VRT of the whole ``source`` (a path relative to the VRT), on ``like``'s grid."""
    with rasterio.open(like) as src:
        srs = src.crs.to_wkt().replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;") \
            .replace('"', "&quot;")
        geotransform = ", ".join(repr(v) for v in src.transform.to_gdal())
    rows, cols = shape
    path.write_text(f"""<VRTDataset rasterXSize="{cols}" rasterYSize="{rows}">
  <SRS>{srs}</SRS>
  <GeoTransform>{geotransform}</GeoTransform>
  <VRTRasterBand dataType="Float32" band="1">
    <SimpleSource>
      <SourceFilename relativeToVRT="1">{source}</SourceFilename><SourceBand>1</SourceBand>
      <SrcRect xOff="0" yOff="0" xSize="{cols}" ySize="{rows}"/>
      <DstRect xOff="0" yOff="0" xSize="{cols}" ySize="{rows}"/>
    </SimpleSource>
  </VRTRasterBand>
</VRTDataset>
""")
    return path


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_vrt_reads_as_its_source_and_its_source_is_never_an_output(tmp_path: Path) -> None:
    dem = write_geotiff(tmp_path / "dem.tif", synthesize("mountain", (48, 40), 500.0, 3).astype(np.float32))
    vrt = write_vrt(tmp_path / "dem.vrt", "dem.tif", (48, 40), dem)
    before = digest(dem)
    assert run_cli("erode", dem, tmp_path / "direct.tif", "--steps", 2, "-q").returncode == 0
    result = run_cli("erode", vrt, tmp_path / "via_vrt.tif", "--steps", 2, "-q")
    assert result.returncode == 0, result.stderr
    with rasterio.open(tmp_path / "direct.tif") as a, rasterio.open(tmp_path / "via_vrt.tif") as b:
        assert np.array_equal(a.read(1), b.read(1)) and a.crs == b.crs and a.transform == b.transform

    refused = run_cli("erode", vrt, dem, "--steps", 2, "--overwrite")
    assert_refused(refused, mentions=f"output {dem} is also an input of this command (read by {vrt})")
    (tmp_path / "link.tif").symlink_to(dem)
    assert_refused(run_cli("flow", vrt, tmp_path / "link.tif", "--overwrite"), mentions="read by")
    assert digest(dem) == before


def test_a_vrt_whose_source_is_missing_is_refused(tmp_path: Path) -> None:
    dem = write_geotiff(tmp_path / "dem.tif", np.full((8, 8), 100.0, np.float32))
    vrt = write_vrt(tmp_path / "broken.vrt", "gone.tif", (8, 8), dem)
    out = tmp_path / "out.tif"
    assert_refused(run_cli("erode", vrt, out, "--steps", 2), out, mentions="gone.tif")
