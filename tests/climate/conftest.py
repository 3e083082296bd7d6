"""The real chronologies of ../shared/data, read once per test session."""

from __future__ import annotations

import pytest
from tests.conftest import SHARED_DATA

from unerode_cli.climate.chronology import Series
from unerode_cli.io.chronology_files import read_series

LR04 = SHARED_DATA / "lr04" / "LR04stack.txt"
MIS_BOUNDARIES = SHARED_DATA / "lr04" / "LR04_MISboundaries.txt"
SPRATT = SHARED_DATA / "sealevel" / "spratt2016.txt"
BINTANJA = SHARED_DATA / "sealevel" / "bintanja_vandewal2008_3Myr.csv"


@pytest.fixture(scope="session")
def lr04() -> Series:
    return read_series(LR04, "d18o")


@pytest.fixture(scope="session")
def spratt() -> Series:
    return read_series(SPRATT, "sea-level")


@pytest.fixture(scope="session")
def bintanja() -> Series:
    return read_series(BINTANJA, "sea-level")
