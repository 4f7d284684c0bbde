"""ORB / SIFT matching against a known homography; stereo matching with the epipolar check."""
import cv2
import numpy as np
import pytest

from rigs.model import Camera, Rig
from vo.errors import VoError
from rigs.geometry import make_T
from vo.frontend.correspondences import correspondences
from vo.frontend.descriptors import match_stereo


def stereo_rig(width=320, height=240):
    """Rectified rig: c1 is 0.2 m to the right of c0 (+x of the OpenCV camera), fx = 300 px."""
    R_b_c = np.array([[0, 0, 1], [-1, 0, 0], [0, -1, 0]])
    cams = tuple(Camera(n, width, height, 300, 300, (width - 1) / 2, (height - 1) / 2, T_b_c=make_T(R_b_c, [0, y, 1]))
                 for n, y in (("cam0", 0.1), ("cam1", -0.1)))
    return Rig("test", cams)


def textured(seed=0, h=240, w=320):
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur(rng.random((h, w)), (0, 0), 1.5)
    return np.round(20 + 215 * (t - t.min()) / (t.max() - t.min())).astype(np.uint8)


@pytest.mark.parametrize("kind", ["orb", "sift"])
def test_matches_consistent_with_homography(kind):
    img_a = textured(1)
    H = np.array([[1.02, 0.03, -6.0], [-0.02, 0.99, 4.0], [1e-5, -2e-5, 1.0]])
    img_b = cv2.warpPerspective(img_a, H, (320, 240), flags=cv2.INTER_LINEAR)
    p_a, p_b = correspondences(img_a, img_b, kind)
    assert len(p_a) > 50
    pred = cv2.perspectiveTransform(p_a.reshape(-1, 1, 2), H).reshape(-1, 2)
    err = np.linalg.norm(pred - p_b, axis=1)
    # ratio test + cross-check leave few outliers; key point localisation (ORB: pyramid-level rounding) < 2 px
    assert np.mean(err < 2.0) > 0.9, np.mean(err < 2.0)


def test_match_stereo_epipolar_and_unknown_kind():
    rig = stereo_rig()
    left = textured(2)
    right = np.roll(left, -8, axis=1)       # constant disparity 8 px on a rectified rig
    p_l, p_r = match_stereo(left, right, "sift", rig)
    assert len(p_l) > 50
    assert np.abs(p_l[:, 1] - p_r[:, 1]).max() < 1.0      # epipolar check: same row within 1 px
    assert np.mean(np.abs(p_l[:, 0] - p_r[:, 0] - 8) < 1.0) > 0.9
    with pytest.raises(VoError, match="valid: klt, orb, sift"):
        correspondences(left, right, "surf")
