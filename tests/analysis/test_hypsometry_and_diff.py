"""Hypsometry (001 Fig. 15) against analytic shapes, and the difference of two DEMs."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from tests.conftest import run_cli, write_geotiff

from unerode_cli.analysis.difference import difference
from unerode_cli.analysis.hypsometry import hypsometry


def cone(n: int = 801, height: float = 1000.0) -> np.ndarray:
    """A cone z = H(1 − r/R) on a disc of radius R, nodata (NaN) outside."""
    y, x = np.mgrid[-1:1:n * 1j, -1:1:n * 1j]
    r = np.hypot(x, y)
    return np.where(r <= 1.0, height * (1.0 - r), np.nan)


def test_cone_hypsometry_matches_its_analytic_distribution() -> None:
    result = hypsometry(cone(), bins=20, normalise="max")
    # share of the disc's area with h/H in [a, b]: (1 − a)² − (1 − b)²
    lower, upper = result.edges[:-1], result.edges[1:]
    expected = (1.0 - lower) ** 2 - (1.0 - upper) ** 2
    np.testing.assert_allclose(result.fraction, expected, atol=2e-3)
    assert result.fraction.sum() == pytest.approx(1.0, abs=1e-12)
    assert result.integral == pytest.approx(1.0 / 3.0, abs=2e-3)  # HI of a cone
    assert result.mode_m == pytest.approx(25.0, abs=1e-9)  # the lowest of 20 bins of 50 m
    np.testing.assert_allclose(result.area_above, (1.0 - lower) ** 2, atol=2e-3)


def test_ramp_is_uniform_and_normalisations_rescale_the_axis() -> None:
    ramp = np.tile(np.linspace(100.0, 300.0, 1001), (50, 1))
    metres = hypsometry(ramp, bins=10, normalise="none")
    np.testing.assert_allclose(metres.fraction, 0.1, atol=1e-3)
    assert metres.integral == pytest.approx(0.5, abs=1e-9)
    assert metres.edges[0] == pytest.approx(100.0) and metres.edges[-1] == pytest.approx(300.0)
    assert hypsometry(ramp, 10, "max").edges[0] == pytest.approx(100.0 / 300.0)
    relative = hypsometry(ramp, 10, "range")
    assert (relative.edges[0], relative.edges[-1]) == pytest.approx((0.0, 1.0))
    with pytest.raises(ValueError, match="highest elevation"):
        hypsometry(ramp - 1000.0, 10, "max")


def test_difference_statistics() -> None:
    rng = np.random.default_rng(3)
    a = rng.normal(500.0, 50.0, (40, 30))
    noise = rng.normal(0.0, 2.0, a.shape)
    b = a + 3.0 + noise
    a[0, 0] = np.nan
    d, stats = difference(a, b)
    assert np.isnan(d[0, 0]) and stats.cells == a.size - 1
    values = (3.0 + noise).ravel()[1:]
    assert stats.rmse_m == pytest.approx(np.sqrt(np.mean(values**2)), rel=1e-12)
    assert stats.mean_m == pytest.approx(values.mean(), rel=1e-12)
    assert stats.max_m == pytest.approx(values.max())
    assert stats.correlation == pytest.approx(0.9992, abs=5e-4)


def test_diff_and_hypsometry_commands(tmp_path: Path) -> None:
    transform = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)
    z = cone(101).astype(np.float32)
    a = write_geotiff(tmp_path / "a.tif", np.nan_to_num(z, nan=-9999.0), transform, nodata=-9999.0)
    b = write_geotiff(tmp_path / "b.tif", np.nan_to_num(z + 5.0, nan=-9999.0), transform, nodata=-9999.0)
    result = run_cli("diff", a, b, tmp_path / "d.tif", "--preview", tmp_path / "d.png")
    assert result.returncode == 0, result.stderr
    assert float(result.stdout.split("RMSE ")[1].split()[0]) == pytest.approx(5.0, abs=1e-4)
    with rasterio.open(tmp_path / "d.tif") as src:
        d = src.read(1, masked=True)
    assert float(d.min()) == pytest.approx(5.0, abs=1e-4) and float(d.max()) == pytest.approx(5.0, abs=1e-4)
    assert int(d.mask.sum()) == int(np.isnan(z).sum())
    sidecar = json.loads((tmp_path / "d.tif.json").read_text())
    assert sidecar["statistics"]["rmse_m"] == pytest.approx(5.0, abs=1e-4)
    assert (tmp_path / "d.png").stat().st_size > 10_000

    other = write_geotiff(tmp_path / "small.tif", np.zeros((10, 10), np.float32), transform)
    mismatch = run_cli("diff", a, other, tmp_path / "e.tif")
    assert mismatch.returncode == 2 and "cells but the DEM has" in mismatch.stderr
    assert not (tmp_path / "e.tif").exists()

    hyp = run_cli("hypsometry", a, b, "--csv", tmp_path / "h.csv", "--plot", tmp_path / "h.png",
                  "--bins", "10")
    assert hyp.returncode == 0, hyp.stderr
    with (tmp_path / "h.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 20
    for name in ("a.tif", "b.tif"):
        assert sum(float(r["area_fraction"]) for r in rows if r["dem"] == name) == pytest.approx(1.0)
    first = hyp.stdout.splitlines()[1].split("\t")
    assert first[0] == "a.tif" and float(first[-1]) == pytest.approx(1.0 / 3.0, abs=0.02)
    import matplotlib.image

    image = matplotlib.image.imread(tmp_path / "h.png")
    assert float(image[..., :3].std()) > 0.05
