"""The support-weight disparity refinement of docs/studies/stereo_support_weights.py on exact synthetic pairs.

Right images are the left ones shifted by a known disparity (bilinear, so sub-pixel shifts are exact up to the
interpolation): on one textured plane the refinement returns the shift from a start 0.8 px off; at a depth edge
(a bright textured square at 6 px of disparity over a dark background at 4 px) the 21x21 LK next to the square
follows the square, and the weights bring most of those points to the side of their centre pixel.
"""
import cv2
import numpy as np
import pytest

from tests.studies import load_study

study = load_study("stereo_support_weights")


def _texture(h, w, seed):
    rng = np.random.default_rng(seed)
    return cv2.GaussianBlur(rng.uniform(0, 255, (h, w)).astype(np.float32), (0, 0), 1.5)


def _shift(img, d):
    """The image seen d px to the left: right(u, v) = img(u + d, v)."""
    h, w = img.shape
    u, v = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
    return cv2.remap(img, u + np.float32(d), v, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)


def test_one_plane_the_refinement_returns_the_shift():
    left = _texture(120, 200, 0)
    right = _shift(left, 7.3)
    p = np.array([[60.0 + 8 * i, 40.0 + 5 * (i % 8)] for i in range(12)])
    d = study.refine(left.astype(np.uint8), right.astype(np.uint8), p, np.full(len(p), 7.3 + 0.8))
    assert np.abs(d - 7.3).max() < 0.1, d


def test_at_a_depth_edge_the_weights_follow_the_centre_pixel():
    """Dark background texture at disparity 4, a bright textured square at disparity 6 (u = 100-200 in the left
    image). On the background 2.5 px right of the square (visible in both images) the 21x21 window is partly the
    square, whose edge dominates its gradients: the LK returns the square's 6 px. The refinement, weighting the
    window by grey-level similarity to the dark centre pixel, brings most of them to the background's 4 px (measured:
    6 of 10 within 0.01 px; the others stay on the square's side, 6.3-6.6 px)."""
    h, w = 140, 260
    back, front = _texture(h, w, 1) * 0.5, 128 + _texture(h, w, 2) * 0.5
    mask = np.zeros((h, w), np.float32)
    mask[30:110, 100:200] = 1.0
    left = back * (1 - mask) + front * mask
    r_back, r_front, r_mask = _shift(back, 4.0), _shift(front, 6.0), _shift(mask, 6.0)
    right = r_back * (1 - r_mask) + r_front * r_mask
    L, R = left.astype(np.uint8), right.astype(np.uint8)
    p = np.array([[202.5, 50.0 + 4 * i] for i in range(10)])
    p_r, st, _ = cv2.calcOpticalFlowPyrLK(L, R, p.astype(np.float32).reshape(-1, 1, 2),
                                          (p - [4.0, 0.0]).astype(np.float32).reshape(-1, 1, 2), winSize=(21, 21),
                                          maxLevel=0, flags=cv2.OPTFLOW_USE_INITIAL_FLOW,
                                          criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01))
    assert st.all()
    d_lk = p[:, 0] - p_r.reshape(-1, 2)[:, 0]
    d_w = study.refine(L, R, p, d_lk)
    assert np.abs(d_lk - 6.0).max() < 0.1, d_lk                 # the window follows the square's edge
    assert np.sum(np.abs(d_w - 4.0) < 0.05) >= 5, d_w            # the weights: the centre pixel's surface


@pytest.mark.parametrize("args, message", [(["drift", "/nonexistent/x", "/tmp/o"], "dataset folder not found")])
def test_bad_input_is_one_line(args, message, tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        study.main(args)
    assert e.value.code == 2
    assert message in capsys.readouterr().err
