"""The stereo epipolar gate around the frame's own row offset (vo.frontend.epipolar_offset), against exact truth.

A rectified synthetic rig (epipolar lines are image rows); the right image is the left one shifted by an
exact band-limited sub-pixel shift of (-disparity, +dy), so every correct match lies exactly ``dy`` px off
its calibrated epipolar line, as under a rectification error of ``dy``.
"""
import numpy as np
import pytest

from vo.frontend.epipolar_offset import estimate_row_offset, offset_epipolar_mask
from vo.frontend.stereo import signed_epipolar_distances
from vo.frontend.klt import KltConfig, stereo_klt
from vo.frontend.stereo import epipolar_distances, fundamental_from_rig
from helpers.stereo_pair import grid_points, shifted, stereo_rig, texture

def test_signed_distance_is_the_row_offset_on_a_rectified_rig():
    rig = stereo_rig()
    F = fundamental_from_rig(rig)
    x0 = grid_points(240, 320)
    for dy in (-1.3, 0.4, 2.0):
        x1 = x0 + [-15.0, dy]
        r = signed_epipolar_distances(F, x0, x1)
        assert np.allclose(np.abs(r), epipolar_distances(F, x0, x1), atol=1e-12)
        assert np.allclose(np.abs(r), abs(dy), atol=1e-9)
        # one sign for one direction of the offset, the other for the other
        assert np.all(np.sign(r) == np.sign(r[0])) and np.sign(r[0]) == np.sign(dy) * np.sign(
            signed_epipolar_distances(F, x0[:1], x0[:1] + [-15.0, 1.0])[0])


def test_robust_offset_ignores_a_third_of_wrong_matches():
    rng = np.random.default_rng(31)
    good = 1.3 + 0.15 * rng.standard_normal(200)
    bad = rng.uniform(-6.0, 6.0, 100)             # wrong matches, spread over the search range
    est = estimate_row_offset(np.r_[good, bad])
    assert est.used and est.n == 300
    # the median of N(1.3, 0.15) over 200 draws is within ~0.011 px (1 sigma); the outliers shift
    # the plain median by ~0.1 px, the trimmed step brings it back: 0.05 px bound
    assert abs(est.offset - 1.3) < 0.05, est
    assert not estimate_row_offset(good[:9]).used                      # fewer than min_matches
    assert not estimate_row_offset(good + 3.0).used                    # beyond max_offset_px: gate at 0
    assert estimate_row_offset(good + 3.0).offset == 0.0


@pytest.mark.parametrize("dy", [1.3, -0.8])
def test_stereo_klt_keeps_matches_off_the_line_by_a_known_row_offset(dy):
    rig = stereo_rig()
    disparity = 6.0
    f0 = texture(5)
    left = np.round(f0).astype(np.uint8)
    right = np.round(shifted(f0, -disparity, dy)).astype(np.uint8)
    p_l = grid_points(240, 320)
    p_r, ok = stereo_klt(left, right, p_l, rig, KltConfig())
    _, est = offset_epipolar_mask(rig, p_l, p_r)
    assert ok.mean() > 0.95, ok.mean()
    assert abs(abs(est.offset) - abs(dy)) < 0.02, est          # exact shift: only uint8 rounding perturbs LK
    assert np.abs(p_r[ok] - (p_l[ok] + [-disparity, dy])).max() < 0.05
    # seed 003's gate around the calibrated line rejects what lies beyond 1 px of it
    _, ok_plain = stereo_klt(left, right, p_l, rig, KltConfig(offset_max_px=0))
    assert ok_plain.mean() == (0.0 if abs(dy) > 1 else ok.mean())


def test_without_an_offset_the_gate_is_seed_003s():
    rig = stereo_rig()
    f0 = texture(6)
    left = np.round(f0).astype(np.uint8)
    right = np.round(shifted(f0, -6.0, 0.0)).astype(np.uint8)
    p_l = grid_points(240, 320)
    p_r, ok = stereo_klt(left, right, p_l, rig, KltConfig())
    _, est = offset_epipolar_mask(rig, p_l, p_r)
    assert abs(est.offset) < 0.02
    assert np.array_equal(ok, stereo_klt(left, right, p_l, rig, KltConfig(offset_max_px=0))[1])
