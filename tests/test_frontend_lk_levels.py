"""OpenCV's pyramidal LK from pyramids built once (vo.frontend.lk_levels) against ``cv2.calcOpticalFlowPyrLK``
itself: exact truth, the same float32 positions and statuses to the bit."""
import cv2
import numpy as np
import pytest

from vo.frontend.lk_levels import RawPyramidCache, lk_native_levels, raw_pyramid
from helpers.stereo_pair import shifted, texture

CRIT = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01)


def _pair(seed, shape, du, dv):
    rng = np.random.default_rng(seed)
    f0 = texture(seed, *shape)
    noisy = lambda f: np.clip(np.rint(f + rng.normal(0, 2.0, f.shape)), 0, 255).astype(np.uint8)  # noqa: E731
    return noisy(f0), noisy(shifted(f0, du, dv))


@pytest.mark.parametrize("shape, win, max_level", [((240, 320), 21, 3), ((240, 320), 11, 5), ((90, 130), 21, 4)])
def test_levels_give_opencv_lk_to_the_bit(shape, win, max_level):
    """Points over the whole image and beyond its border (some fail), a flow of (6.3, -2.4) px, started at zero
    flow and at a noisy guess; the 90 x 130 image stops its pyramid early (OpenCV's rule: a level must stay
    larger than the window)."""
    img0, img1 = _pair(3, shape, 6.3, -2.4)
    rng = np.random.default_rng(4)
    h, w = shape
    p = (rng.random((400, 2)) * [w + 40, h + 40] - 20).astype(np.float32).reshape(-1, 1, 2)
    guess = (p + [6.3, -2.4] + rng.normal(0, 2.0, p.shape)).astype(np.float32)
    pyr0, pyr1 = raw_pyramid(img0, max_level, win), raw_pyramid(img1, max_level, win)
    kw = dict(winSize=(win, win), maxLevel=max_level, criteria=CRIT)
    ref = [cv2.calcOpticalFlowPyrLK(img0, img1, p, None, **kw)[:2],
           cv2.calcOpticalFlowPyrLK(img0, img1, p, guess.copy(), flags=cv2.OPTFLOW_USE_INITIAL_FLOW, **kw)[:2]]
    got = [lk_native_levels(pyr0, pyr1, p, win, CRIT), lk_native_levels(pyr0, pyr1, p, win, CRIT, guess)]
    for (b_ref, st_ref), (b, st) in zip(ref, got):
        assert 0 < st_ref.sum() < len(p)                 # some points tracked, some lost
        assert b.dtype == np.float32 and np.array_equal(b, b_ref) and np.array_equal(st, st_ref)


def test_raw_pyramid_levels_and_cache_identity():
    img = np.zeros((240, 320), np.uint8)
    assert [x.shape for x in raw_pyramid(img, 3, 21)] == [(240, 320), (120, 160), (60, 80), (30, 40)]
    assert len(raw_pyramid(img, 3, 31)) == 3             # 30 x 40 would not exceed a 31 px window
    cache = RawPyramidCache(3, 21, size=2)
    a, b, c = img.copy(), img.copy(), img.copy()
    pa = cache(a)
    assert cache(a) is pa and cache(b) is not pa
    cache(c)
    assert cache(a) is not pa                            # evicted after two newer images
