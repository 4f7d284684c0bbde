"""The depth-edge test of new stereo landmarks (vo.frontend.depth_edge) on exactly rendered stereo pairs.

Synthetic rectified pairs: a blurred random texture painted on surfaces whose disparity is known in closed
form. On one plane (constant or slanted disparity: affine in the pixel) the one-sided second difference of
the disparity vanishes up to the LK error; where a near surface occludes a far one it is the disparity step
seen from the corner.
"""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from vo.errors import VoError
from vo.frontend.depth_edge import edge_score, off_edge
from vo.frontend.klt import KltConfig

H, W = 160, 320


def _texture(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur((rng.random((H, 2 * W)) * 255).astype(np.float32), (0, 0), 1.5)
    return cv2.normalize(t, None, 0, 255, cv2.NORM_MINMAX)


def _sample(tex: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return cv2.remap(tex, x.astype(np.float32), y.astype(np.float32), cv2.INTER_LINEAR)


def _plane_pair(a: float, b: float, c: float):
    """Left image = texture; the right pixel (x, y) sees the left pixel u with u - (a + b u + c y) = x."""
    tex = _texture(1)
    y, x = np.mgrid[0:H, 0:W].astype(np.float64)
    left = _sample(tex, x, y)
    right = _sample(tex, (x + a + c * y) / (1 - b), y)
    return left.astype(np.uint8), right.astype(np.uint8), lambda p: a + b * p[:, 0] + c * p[:, 1]


def _step_pair(edge_u: float, d_near: float, d_far: float):
    """Near surface left of column ``edge_u`` (left image), far surface right of it; the near one occludes."""
    near, far = _texture(2), _texture(3)
    y, x = np.mgrid[0:H, 0:W].astype(np.float64)
    left = np.where(x < edge_u, _sample(near, x, y), _sample(far, x, y))
    right = np.where(x + d_near < edge_u, _sample(near, x + d_near, y), _sample(far, x + d_far, y))
    return left.astype(np.uint8), right.astype(np.uint8)


def _points(u: np.ndarray, v: float = H / 2) -> np.ndarray:
    return np.column_stack([u, np.full(len(u), v)]).astype(np.float64)


@pytest.mark.parametrize("a,b,c", [(10.0, 0.0, 0.0), (8.0, 0.03, 0.0), (4.0, 0.0, 0.12)])
def test_points_on_one_plane_score_near_zero(a, b, c):
    left, right, disparity = _plane_pair(a, b, c)
    p_l = _points(np.arange(60.0, 260.0, 20.0))
    p_r = p_l - np.column_stack([disparity(p_l), np.zeros(len(p_l))])
    score = edge_score(left, right, p_l, p_r)
    # LK on an 8-bit, linearly interpolated texture: offsets within ~0.1 px on a fronto-parallel plane; a vertical
    # disparity gradient shears the 11x11 window (0.12 px/px spreads its rows over 1.3 px of disparity), which
    # moves each sample's disparity by up to ~0.3 px: second differences stay below 1 px, half the 2 px threshold
    assert np.all(score < 1.0), score
    assert np.all(off_edge(left, right, p_l, p_r, KltConfig(edge_threshold_px=2.0)))


def test_corners_at_an_occlusion_score_the_disparity_step():
    d_near, d_far, edge_u = 14.0, 4.0, 160.0
    left, right = _step_pair(edge_u, d_near, d_far)
    u = np.array([edge_u - 2, edge_u - 1, edge_u, edge_u + 1, edge_u + 2])
    p_l = _points(u)
    # the front-end's 21x21 match at a boundary lies between the sides: start half-way
    p_r = p_l - np.column_stack([np.full(len(u), (d_near + d_far) / 2), np.zeros(len(u))])
    score = edge_score(left, right, p_l, p_r)
    # one side of the corner's 11-px window lies 10 px of disparity away; a mixed centre sees >= 2 px of it
    assert np.all(score > 2.0), score
    assert not np.any(off_edge(left, right, p_l, p_r, KltConfig(edge_threshold_px=2.0)))
    # far from the boundary (beyond 2 s + the window) the same pair passes
    far_pts = _points(np.array([60.0, 260.0]))
    far_r = far_pts - np.array([[d_near, 0.0], [d_far, 0.0]])
    assert np.all(edge_score(left, right, far_pts, far_r) < 0.5)


def test_threshold_zero_turns_the_test_off_and_is_the_default_and_empty_input_is_empty():
    assert KltConfig().edge_threshold_px == 0.0
    left, right = _step_pair(160.0, 14.0, 4.0)
    p_l = _points(np.array([160.0]))
    off = KltConfig(edge_threshold_px=0.0)
    assert off_edge(left, right, p_l, p_l - [9.0, 0.0], off).tolist() == [True]
    assert edge_score(left, right, np.zeros((0, 2)), np.zeros((0, 2))).shape == (0,)


@pytest.mark.parametrize("field,value", [("edge_win", 4), ("edge_win", 1), ("edge_threshold_px", -1.0)])
def test_bad_edge_settings_are_vo_errors_naming_the_field(field, value):
    with pytest.raises(VoError, match=field):
        KltConfig(**{field: value})
