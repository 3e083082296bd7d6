"""Cell sizes in metres from the CRS (DESIGN §4)."""

from __future__ import annotations

import pytest
from affine import Affine
from pyproj import CRS

from unerode_cli.errors import InputError
from unerode_cli.io.cellsize import cell_size_metres

ARCSEC = 1.0 / 3600.0
WGS84 = CRS.from_epsg(4326).to_wkt()


def one_arcsec_grid(lat: float) -> Affine:
    return Affine(ARCSEC, 0.0, 7.0 - 50 * ARCSEC, 0.0, -ARCSEC, lat + 50 * ARCSEC)


def test_one_arcsecond_at_45_north() -> None:
    size = cell_size_metres(WGS84, one_arcsec_grid(45.0), (100, 100), "t")
    assert size.dx == pytest.approx(21.9, rel=5e-3)
    assert size.dy == pytest.approx(30.9, rel=5e-3)


def test_one_arcsecond_at_the_equator() -> None:
    # East-west: equatorial radius 6378137 m × 1″ = 30.92 m. North-south: the meridian arc
    # at the equator is shorter (radius of curvature a(1 − e²) = 6335439 m → 30.72 m).
    size = cell_size_metres(WGS84, one_arcsec_grid(0.0), (100, 100), "t")
    assert size.dx == pytest.approx(30.9, rel=5e-3)
    assert size.dy == pytest.approx(30.72, rel=5e-3)
    assert size.dx == pytest.approx(size.dy, rel=1e-2)


def test_us_survey_feet_are_converted() -> None:
    size = cell_size_metres(CRS.from_epsg(2229).to_wkt(), Affine(10, 0, 0, 0, -10, 0), (2, 2), "t")
    assert size.dx == pytest.approx(3.048006, rel=1e-6)


def test_no_crs_assumes_metres(capsys: pytest.CaptureFixture[str]) -> None:
    size = cell_size_metres("", Affine(2.5, 0, 0, 0, -2.5, 0), (2, 2), "dem.asc")
    assert (size.dx, size.dy) == (2.5, 2.5)
    assert "metres" in capsys.readouterr().err


@pytest.mark.parametrize("transform", [Affine(30, 2, 0, 1, -30, 0), Affine(30, 0, 0, 0, 30, 0)])
def test_rotated_or_south_up_is_refused(transform: Affine) -> None:
    with pytest.raises(InputError, match="north-up|rotated"):
        cell_size_metres(WGS84, transform, (2, 2), "t")
