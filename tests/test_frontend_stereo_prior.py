"""The disparity prior of new stereo corners (vo.frontend.stereo_prior), against exact truth."""
import numpy as np
import pytest

from rigs.geometry import inv_T, make_T, transform_points
from vo.frontend.klt import KltConfig, stereo_klt
from vo.frontend.stereo_prior import disparity_guess, landmark_refs
from helpers.stereo_pair import grid_points, shifted, stereo_rig, texture


def test_guess_takes_the_median_disparity_of_the_nearest_references():
    rng = np.random.default_rng(3)
    near_left = rng.uniform([20, 20], [140, 220], (30, 2))          # left half: 40 px disparity
    far_left = rng.uniform([180, 20], [300, 220], (30, 2))          # right half: 8 px
    ref_left = np.r_[near_left, far_left]
    ref_right = ref_left - np.r_[np.tile([40.0, 0.0], (30, 1)), np.tile([8.0, 0.0], (30, 1))]
    ref_right[0] += [25.0, 3.0]                                     # one wrong reference: outvoted by the median
    p_new = np.array([[80.0, 120.0], [240.0, 120.0]])
    g = disparity_guess(p_new, ref_left, ref_right, k=8)
    assert np.allclose(g, p_new - [[40.0, 0.0], [8.0, 0.0]], atol=1e-12)
    assert disparity_guess(p_new, ref_left[:4], ref_right[:4]) is None     # fewer than min_refs


def test_landmark_refs_project_into_the_right_camera():
    rig = stereo_rig()
    cam = rig.cameras[0]
    p_c0 = np.array([[0.5, -0.2, 3.0], [-1.0, 0.3, 6.0], [0.0, 0.0, -2.0]])    # the last is behind
    T_o_c0 = make_T(np.eye(3), [1.0, 2.0, 0.5])
    p_o = transform_points(T_o_c0, p_c0)
    px = (cam.K @ (p_c0 / p_c0[:, 2:]).T).T[:, :2]
    ref_l, ref_r = landmark_refs(rig, inv_T(T_o_c0), p_o, px)
    assert len(ref_l) == 2
    # rectified rig, baseline 0.2 m, f 300: disparity f b / Z along the row
    assert np.allclose(ref_l - ref_r, np.c_[300 * 0.2 / p_c0[:2, 2], np.zeros(2)], atol=1e-9)


@pytest.mark.parametrize("disparity", [30.0, 45.0])
def test_prior_finds_the_disparity_zero_disparity_lk_cannot_reach(disparity):
    """A fine texture (blur 1.5 px) leaves the coarse pyramid levels nearly flat: LK from zero disparity
    finds (almost) none of the matches; started 2.5 px from the truth it finds all, to 0.05 px (uint8 rounding)."""
    rig = stereo_rig()
    f0 = texture(7, blur=1.5)
    left = np.round(f0).astype(np.uint8)
    right = np.round(shifted(f0, -disparity, 0.0)).astype(np.uint8)
    p_l = grid_points(240, 320, step=20, margin=60)
    p_l = p_l[p_l[:, 0] - disparity > 20]
    _, ok0 = stereo_klt(left, right, p_l, rig, KltConfig())
    p_r, ok = stereo_klt(left, right, p_l, rig, KltConfig(), prior=p_l - [disparity - 2.5, 0.0])
    assert ok0.mean() < 0.05, ok0.mean()
    assert ok.all()
    assert np.abs(p_r - (p_l - [disparity, 0.0])).max() < 0.05
