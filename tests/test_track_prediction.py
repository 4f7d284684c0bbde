"""The predicted start of ``klt-pnp``'s temporal LK (``vo.estimators.track_prediction``) and the mirrored backward
search of ``vo.frontend.klt.track_fb``: exact projections, and tracks of a synthetic shift beyond the pyramid's
reach against the true shift."""
import cv2
import numpy as np
import pytest

from rigs.geometry import make_T
from rigs.presets import build_cart27
from vo.estimators.track_prediction import MIN_DEPTH_M, predicted_pixels, track_guess
from vo.frontend.klt import KltConfig, KltTracker, track_fb


def test_prediction_is_the_lens_projection_at_the_predicted_pose():
    cam = build_cart27().cameras[0]                       # with lens distortion
    rng = np.random.default_rng(5)
    p_c = np.c_[rng.uniform(-6, 6, (40, 2)), rng.uniform(4, 30, 40)]
    T = make_T(cv2.Rodrigues(np.array([0.02, -0.1, 0.01]))[0], np.array([0.3, -0.1, 1.2]))   # T_o_c0 predicted
    p_o = (T[:3, :3] @ p_c.T).T + T[:3, 3]
    pts = rng.uniform(0, 400, (40, 2))
    uv = cam.project(p_c)
    inside = (uv[:, 0] >= 0) & (uv[:, 1] >= 0) & (uv[:, 0] <= cam.width - 1) & (uv[:, 1] <= cam.height - 1)
    assert inside.sum() > 20 and (~inside).sum() > 0
    out = predicted_pixels(cam, T, p_o, pts)
    np.testing.assert_allclose(out[inside], uv[inside], atol=1e-9)
    np.testing.assert_array_equal(out[~inside], pts[~inside])          # outside the image: zero flow
    behind = (T[:3, :3] @ np.array([[0.0, 0.0, -5.0], [0.0, 0.0, 0.5 * MIN_DEPTH_M]]).T).T + T[:3, 3]
    np.testing.assert_array_equal(predicted_pixels(cam, T, behind, pts[:2]), pts[:2])
    ids = np.array([7, 3, 9])                                          # id 9 has no landmark: zero flow
    g = track_guess(cam, T, {7: p_o[0], 3: p_o[1]}, ids, pts[:3])
    np.testing.assert_allclose(g[:2], predicted_pixels(cam, T, p_o[:2], pts[:2]), atol=0)
    np.testing.assert_array_equal(g[2], pts[2])


def test_a_shift_beyond_the_pyramid_is_tracked_from_the_prediction(shifted):
    img0, img1, p0, truth = shifted
    cfg = KltConfig()
    tracker = KltTracker(img0.shape[1], img0.shape[0], cfg)
    zero = tracker.pyramid
    p_z, ok_z = track_fb(img0, img1, p0, cfg, zero)
    assert ok_z.mean() < 0.2                                           # zero flow: mostly lost
    rng = np.random.default_rng(1)
    guess = truth + rng.uniform(-3, 3, truth.shape)                    # a prediction a few px off
    p_g, ok_g = track_fb(img0, img1, p0, cfg, zero, guess, mirror=True)
    assert ok_g.mean() > 0.95
    assert np.abs(p_g[ok_g] - truth[ok_g]).max() < 0.05
    # the tracker's own call is the same search
    tracker.detect(img0)
    tracker.pts, tracker.ids = p0.copy(), np.arange(len(p0))
    alive = tracker.track(img1, guess)
    np.testing.assert_array_equal(alive, ok_g)
    np.testing.assert_allclose(tracker.pts, p_g[ok_g], atol=0)


def test_the_mirrored_round_trip_rejects_wrong_matches(shifted):
    """Predictions 3 px or 25 px off: every track that passes the forward-backward and ZNCC checks is the true match
    (0.1 px). A random prediction (+-60 px): wrong matches pass only as the ZNCC gate lets an unrelated window
    through (about 1 % at 0.5 on this texture): at most 2 of the corners, and no more than with the backward
    search started at ``p0`` (VINS-Fusion's reverse check) or with seed 003's zero flow, whose searches beyond
    their reach end on wrong matches that agree both ways."""
    img0, img1, p0, truth = shifted
    cfg = KltConfig()
    pyr = KltTracker(img0.shape[1], img0.shape[0], cfg).pyramid
    rng = np.random.default_rng(2)

    def wrong(guess, mirror):
        p1, ok = track_fb(img0, img1, p0, cfg, pyr, guess, mirror=mirror)
        return int(np.sum(ok & (np.linalg.norm(p1 - truth, axis=1) > 0.1))), int(ok.sum())

    for guess in (truth + rng.uniform(-3, 3, truth.shape), truth + [25.0, -12.0]):
        n_wrong, n_ok = wrong(guess, True)
        assert n_wrong == 0 and n_ok > 0.6 * len(p0)
    far = p0 + rng.uniform(-60, 60, p0.shape) + [110.0, 0.0]
    n_wrong, _ = wrong(far, True)
    zero_wrong, zero_ok = wrong(None, False)
    assert n_wrong <= 2 and n_wrong <= wrong(far, False)[0] and n_wrong <= zero_wrong
    assert zero_wrong == zero_ok > 0                  # zero flow beyond its reach: what passes is wrong
