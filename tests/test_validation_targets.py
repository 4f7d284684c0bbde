"""Target-board scene for the range validation: texture, layout geometry, validation errors."""
import numpy as np
import pytest

from rigs.presets import get_rig
from scenes.base import SceneConfig
from scenes.errors import SceneError
from sim.app.validation.targets import Board, TargetScene, board_layout, board_texture


def test_board_texture_is_seeded_and_not_self_similar():
    a, b = board_texture(7, 128), board_texture(7, 128)
    assert a.tobytes() == b.tobytes() and a.tobytes() != board_texture(8, 128).tobytes()
    g = a.astype(float).mean(axis=2)
    patch = g[40:61, 40:61] - g[40:61, 40:61].mean()
    # normalised correlation of a 21x21 patch with every other same-size patch: only the true
    # position may match well (a repetitive texture would give other peaks near 1)
    best = 0.0
    for y in range(0, 107, 3):
        for x in range(0, 107, 3):
            if abs(y - 40) < 6 and abs(x - 40) < 6:
                continue
            q = g[y:y + 21, x:x + 21] - g[y:y + 21, x:x + 21].mean()
            best = max(best, float((patch * q).sum() / np.sqrt((patch ** 2).sum() * (q ** 2).sum())))
    assert best < 0.8
    assert g.std() > 40   # strong contrast (grey levels)


def test_layout_puts_each_board_on_c0_axis_at_its_range():
    rig = get_rig("stereo27")
    ranges = [2.0, 10.0, 30.0]
    boards, poses = board_layout(rig, ranges, elevation_deg=0.0)
    for bd, T_w_b, r in zip(boards, poses, ranges):
        T_w_c0 = T_w_b @ rig.cameras[0].T_b_c_array
        c_c0 = np.linalg.inv(T_w_c0) @ np.append(bd.center_w, 1.0)
        assert np.allclose(c_c0[:3], [0.0, 0.0, r], atol=1e-9)
        corners_c0 = (np.linalg.inv(T_w_c0) @ np.c_[bd.face_corners_w(), np.ones(4)].T)[:3].T
        assert np.allclose(corners_c0[:, 2], r, atol=1e-9)          # fronto-parallel
        assert corners_c0[0, 0] < 0 and corners_c0[0, 1] < 0        # first corner is top-left in the image


def test_bad_layouts_and_boards_raise_scene_errors():
    rig = get_rig("stereo27")
    with pytest.raises(SceneError, match="spacing"):
        board_layout(rig, np.arange(1, 21))
    with pytest.raises(SceneError, match="ranges"):
        board_layout(rig, [5.0, -1.0])
    with pytest.raises(SceneError, match="half_w"):
        Board("x", (0, 0, 0), tuple(map(tuple, np.eye(3))), half_w=0.0, half_h=1.0)
    b = Board("x", (5, 0, 1), tuple(map(tuple, np.eye(3))), half_w=1.0, half_h=1.0)
    with pytest.raises(SceneError, match="duplicate"):
        TargetScene(SceneConfig(name="targets"), (b, b))
