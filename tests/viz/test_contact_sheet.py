"""The contact sheet of previews: its size, where each image lands, its aspect kept."""

from __future__ import annotations

from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

from unerode_cli.viz.contact_sheet import DPI, PANEL_WIDTH, TITLE_HEIGHT, save_contact_sheet, sheet_layout

COLOURS = {"red": (1.0, 0.0, 0.0), "green": (0.0, 1.0, 0.0), "blue": (0.0, 0.0, 1.0)}


def _solid(colour: tuple[float, float, float], height: int = 30, width: int = 60) -> np.ndarray:
    return np.broadcast_to(np.asarray(colour, dtype=np.float32), (height, width, 3)).copy()


def test_three_images_on_two_columns_read_left_to_right_top_to_bottom(tmp_path: Path) -> None:
    path = tmp_path / "sheet.png"
    save_contact_sheet(path, [_solid(c) for c in COLOURS.values()], list(COLOURS), columns=2)
    sheet = matplotlib.image.imread(path)[..., :3]
    # two rows of panels 4 in wide, half as tall (the images' aspect) plus a title line, at DPI
    size = (round(2 * (PANEL_WIDTH / 2 + TITLE_HEIGHT) * DPI), round(2 * PANEL_WIDTH * DPI))
    assert sheet.shape[:2] == size
    middle = np.array(sheet.shape[:2]) / 2
    quadrants = {"red": (0, 0), "green": (0, 1), "blue": (1, 0)}
    for name, colour in COLOURS.items():
        rows, cols = np.nonzero(np.all(np.abs(sheet - colour) < 0.02, axis=-1))
        assert (int(rows.mean() > middle[0]), int(cols.mean() > middle[1])) == quadrants[name], name
        # the panel shows the whole image at its aspect (2:1), over most of the panel's width
        width, height = np.ptp(cols) + 1, np.ptp(rows) + 1
        assert width / height == pytest.approx(2.0, rel=0.05), name
        assert width > 0.7 * middle[1] and rows.size == pytest.approx(width * height, rel=0.02), name
    empty = sheet[int(middle[0]):, int(middle[1]):]
    assert np.all(np.ptp(empty, axis=-1) < 0.02)  # the fourth panel is left blank: only greys


def test_each_row_is_as_tall_as_its_tallest_image(tmp_path: Path) -> None:
    """One column: a wide image (aspect 1:2) over a tall one (2:1); the first row takes
    (4 × 0.5 + title) / (4 × 0.5 + 4 × 2 + 2 titles) of the sheet's height."""
    path = tmp_path / "sheet.png"
    save_contact_sheet(path, [_solid(COLOURS["red"]), _solid(COLOURS["blue"], 60, 30)], ["wide", "tall"],
                       columns=1)
    sheet = matplotlib.image.imread(path)[..., :3]
    rows = [PANEL_WIDTH * 0.5 + TITLE_HEIGHT, PANEL_WIDTH * 2.0 + TITLE_HEIGHT]
    assert sheet.shape[:2] == (round(sum(rows) * DPI), round(PANEL_WIDTH * DPI))
    boundary = rows[0] * DPI
    red, _ = np.nonzero(np.all(np.abs(sheet - COLOURS["red"]) < 0.02, axis=-1))
    blue, blue_cols = np.nonzero(np.all(np.abs(sheet - COLOURS["blue"]) < 0.02, axis=-1))
    assert red.max() < boundary < blue.min()
    assert (np.ptp(blue) + 1) / (np.ptp(blue_cols) + 1) == pytest.approx(2.0, rel=0.05)
    assert np.ptp(blue) + 1 > 0.8 * (sheet.shape[0] - boundary)  # the tall image fills its row


def test_the_layout_is_square_ish_unless_columns_are_given() -> None:
    assert [sheet_layout(n) for n in (1, 2, 4, 7, 11)] == [(1, 1), (1, 2), (2, 2), (3, 3), (3, 4)]
    assert sheet_layout(7, columns=4) == (2, 4) and sheet_layout(3, columns=5) == (1, 3)


def test_titles_must_match_the_images(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="2 images but 1 titles"):
        save_contact_sheet(tmp_path / "sheet.png", [_solid(COLOURS["red"])] * 2, ["one"])
    with pytest.raises(ValueError, match="at least one image"):
        save_contact_sheet(tmp_path / "sheet.png", [], [])
