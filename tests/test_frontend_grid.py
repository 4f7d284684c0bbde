"""Grid occupancy, border cells, one-corner-per-cell detection, seed 003's keyframe criterion."""
import numpy as np
import pytest

from vo.errors import VoError
from vo.frontend.grid import Grid
from vo.frontend.klt import KltConfig, detect_in_empty_cells, is_keyframe


def test_cell_index_and_counts():
    g = Grid(100, 70, cell=32)          # 4 x 3 cells, last column/row partial
    assert (g.n_cols, g.n_rows, g.n_cells) == (4, 3, 12)
    pts = np.array([[0, 0], [31.9, 31.9], [32, 0], [99.5, 69.5], [-1, 5], [100, 5], [50, 40]])
    idx = g.cell_index(pts)
    assert idx.tolist() == [0, 0, 1, 11, -1, -1, 5]
    c = g.counts(pts)
    assert c[0] == 2 and c[1] == 1 and c[11] == 1 and c[5] == 1 and c.sum() == 5
    assert g.empty_fraction(pts) == pytest.approx(8 / 12)
    assert g.cell_rect(11) == (96, 64, 100, 70)


def test_border_cells_and_detection_cells():
    g = Grid(160, 128, cell=32)         # 5 x 4 cells; interior = rows 1-2, cols 1-3 -> 6 cells
    assert int((~g.is_border).sum()) == 6
    assert g.is_border[0] and g.is_border[4] and g.is_border[19] and not g.is_border[6]
    occupied = np.array([[40.0, 40.0]])  # cell 6 (row 1, col 1)
    det = g.detection_cells(occupied)
    assert sorted(det.tolist()) == [7, 8, 11, 12, 13]


def test_one_corner_per_empty_interior_cell():
    rng = np.random.default_rng(0)
    img = (rng.random((128, 160)) * 255).astype(np.uint8)   # corners everywhere
    g = Grid(160, 128, 32)
    existing = np.array([[40.0, 40.0]])
    pts = detect_in_empty_cells(img, g, existing, KltConfig())
    idx = g.cell_index(pts)
    # exactly one corner in each of the 5 empty interior cells, none in border cells or the occupied cell
    assert sorted(idx.tolist()) == [7, 8, 11, 12, 13]


def test_blank_image_gives_no_corners():
    g = Grid(160, 128, 32)
    for value in (0, 255):
        img = np.full((128, 160), value, np.uint8)
        assert detect_in_empty_cells(img, g, np.zeros((0, 2))).shape == (0, 2)


def test_keyframe_decision_thresholds():
    cfg = KltConfig()   # 0.42 and 100 (seed 003)
    assert not is_keyframe(0.42, 100, cfg)
    assert is_keyframe(0.4201, 100, cfg)
    assert not is_keyframe(0.4199, 100, cfg)
    assert is_keyframe(0.1, 99, cfg)
    assert not is_keyframe(0.1, 100, cfg)


def test_config_validation_and_levels():
    assert KltConfig().max_level == 3      # 4 pyramid levels = OpenCV maxLevel 3
    with pytest.raises(VoError, match="win"):
        KltConfig(win=20)
    with pytest.raises(VoError, match="width"):
        Grid(0, 10)
