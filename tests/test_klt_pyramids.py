"""The raw-image LK on pyramids built once per image equals OpenCV's own pyramidal LK to the bit."""
import cv2
import numpy as np
import pytest

from vo.frontend.klt import KltConfig, KltTracker, track_fb
from vo.frontend.klt_pyramids import LkPyramids, lk_raw_levels, raw_pyramid
from helpers.stereo_pair import shifted, texture

CRIT = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01)


def _pair(h, w, du, dv, seed=3):
    f = texture(seed, h=h, w=w)
    return np.round(f).astype(np.uint8), np.round(shifted(f, du, dv)).astype(np.uint8)


@pytest.mark.parametrize("h, w, max_level", [(240, 320, 3), (80, 70, 3), (240, 320, 0)])
def test_levels_and_flow_equal_opencv_to_the_bit(h, w, max_level):
    """Points all over the image (borders, outside it), with and without a start guess; an image whose coarse
    levels would be no larger than the window (70x80, 21 px: OpenCV stops at 2 levels) and no pyramid at all."""
    img0, img1 = _pair(h, w, 7.3, -4.6)
    rng = np.random.default_rng(0)
    p0 = np.vstack([rng.uniform([-15, -15], [w + 15, h + 15], (200, 2)), [[0, 0], [w - 1, h - 1], [2.5, h / 2]]])
    guess = p0 + rng.normal(0, 3, p0.shape)
    pyr0, pyr1 = raw_pyramid(img0, 21, max_level), raw_pyramid(img1, 21, max_level)
    assert len(pyr0) == (2 if (h, w) == (80, 70) else max_level + 1)
    for g in (None, guess):
        start = None if g is None else g.astype(np.float32).reshape(-1, 1, 2)
        want, st_want, _ = cv2.calcOpticalFlowPyrLK(img0, img1, p0.astype(np.float32).reshape(-1, 1, 2),
                                                    None if start is None else start.copy(), winSize=(21, 21),
                                                    maxLevel=max_level, criteria=CRIT,
                                                    flags=0 if g is None else cv2.OPTFLOW_USE_INITIAL_FLOW)
        got, st = lk_raw_levels(pyr0, pyr1, p0, 21, 30, 0.01, start)
        assert 0 < st_want.sum() < len(p0)
        np.testing.assert_array_equal(st, st_want)
        np.testing.assert_array_equal(got, want)


def test_tracker_raw_fallback_unchanged_and_pyramids_built_once():
    """track_fb with an LkPyramids (raw fallback on cached pyramids) gives what it gives without one (OpenCV's
    pyramids built on every call), and builds each image's raw pyramid once."""
    img0, img1 = _pair(240, 320, 3.4, 1.2)
    img1[60:140, 80:200] = 255 - img1[60:140, 80:200]           # a region where the normalised LK loses points
    tr = KltTracker(320, 240, KltConfig())
    tr.detect(img0)
    plain = track_fb(img0, img1, tr.pts, KltConfig())
    cache = LkPyramids(KltConfig().levels, KltConfig().box)
    calls = []
    raw = cache.raw
    cache.raw = lambda *a: calls.append(a[0]) or raw(*a)          # count the requests, not the builds
    cached = track_fb(img0, img1, tr.pts, KltConfig(), cache)
    np.testing.assert_array_equal(cached[0], plain[0])
    np.testing.assert_array_equal(cached[1], plain[1])
    assert len(calls) == 2 and len(cache._raw) == 2               # forward and back share the two pyramids
