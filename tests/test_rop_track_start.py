"""``rop``'s second temporal LK search from the tracks' predicted pixels (``vo.rop.track_start``,
``KltFourView.track(..., predict)``) and the mirrored backward search of its front-end (``vo.rop.tracks.lk_fb``):
exact projections of the keyframe stereo points at the predicted pose, a synthetic shift beyond the pyramid's reach
tracked against the true shift, and a ray-cast turn where the second search adds tracks and changes none."""
import cv2
import numpy as np
import pytest

from helpers.synthetic import box_scene, render
from rigs.geometry import inv_T, make_T, rot_y, transform_points
from rigs.presets import build_cart27, get_rig
from vo.frontend.klt import KltConfig
from vo.frontend.klt_pyramids import LkPyramids
from vo.frontend.stereo import triangulate
from vo.rop.relative import normalized_points
from vo.rop.track_start import predicted_left
from vo.rop.tracks import KltFourView, lk_fb

MAX_DEPTH, MAX_TRI_PX = 80.0, 1.0
PINHOLE = get_rig("stereo27")                  # 752x480 pinhole, 0.27 m baseline, no distortion


def _stereo_pair(rig, p_kf):
    """Exact left/right pixels and the left normalised coordinates of keyframe points ``p_kf`` (N,3)."""
    c0, c1 = rig.cameras[:2]
    p1 = c0.project(p_kf)
    p2 = c1.project(transform_points(inv_T(rig.T_c0_c1), p_kf))
    return p1, p2, normalized_points(p1, c0.K, c0.dist_coeffs)


def test_prediction_is_the_keyframe_point_seen_from_the_predicted_pose():
    rig = build_cart27()                                   # with lens distortion
    cam = rig.cameras[0]
    rng = np.random.default_rng(3)
    p_kf = np.c_[rng.uniform(-4, 4, (50, 2)), rng.uniform(4, 40, 50)]
    p1, p2, x1 = _stereo_pair(rig, p_kf)
    T_kf_c = make_T(cv2.Rodrigues(np.array([0.01, 0.12, -0.01]))[0], np.array([0.2, 0.05, 1.5]))
    p3 = p1 + rng.uniform(-2, 2, p1.shape)                 # the tracks' current pixels (kept when not predictable)
    out = predicted_left(rig, T_kf_c, p1, x1, p2, p3, MAX_DEPTH, MAX_TRI_PX)
    uv = cam.project(transform_points(inv_T(T_kf_c), p_kf))
    inside = (uv[:, 0] >= 0) & (uv[:, 1] >= 0) & (uv[:, 0] <= cam.width - 1) & (uv[:, 1] <= cam.height - 1)
    assert inside.sum() > 30 and (~inside).sum() > 0
    np.testing.assert_allclose(out[inside], uv[inside], atol=1e-6)   # triangulation round-off only
    np.testing.assert_array_equal(out[~inside], p3[~inside])


def test_a_track_that_does_not_triangulate_moves_with_the_rotation():
    """Pairs of parallel rays (points at infinity) are predicted on their ray: under a pure rotation that is exact at
    any depth."""
    rig = build_cart27()
    cam = rig.cameras[0]
    rng = np.random.default_rng(4)
    p_kf = np.c_[rng.uniform(-0.2, 0.2, (30, 2)), np.ones(30)] * 1e6        # at infinity, in view
    p1, p2, x1 = _stereo_pair(rig, p_kf)                                    # parallel rays: no triangulation
    assert not triangulate(rig, p1, p2, MAX_DEPTH, MAX_TRI_PX)[1].any()
    T_kf_c = make_T(cv2.Rodrigues(np.array([0.0, 0.08, 0.0]))[0], np.zeros(3))
    out = predicted_left(rig, T_kf_c, p1, x1, p2, p1, MAX_DEPTH, MAX_TRI_PX)
    uv = cam.project(transform_points(inv_T(T_kf_c), p_kf))
    inside = (uv[:, 0] >= 0) & (uv[:, 0] <= cam.width - 1)
    assert inside.sum() > 15 and np.median(np.linalg.norm(uv[inside] - p1[inside], axis=1)) > 30   # 4.6 deg: ~40 px
    np.testing.assert_allclose(out[inside], uv[inside], atol=1e-6)


def test_the_front_end_tracks_a_shift_beyond_the_pyramid_from_the_prediction(shifted):
    img0, img1, p0, truth = shifted
    cfg, pyr = KltConfig(), LkPyramids(KltConfig().levels, KltConfig().box)
    _, ok_z = lk_fb(img0, img1, p0, cfg, pyramid=pyr)
    assert ok_z.mean() < 0.2                                          # zero flow: mostly lost
    guess = truth + np.random.default_rng(1).uniform(-3, 3, truth.shape)
    p_g, ok_g = lk_fb(img0, img1, p0, cfg, guess, pyr, mirror=True)
    assert ok_g.mean() > 0.95 and np.abs(p_g[ok_g] - truth[ok_g]).max() < 0.05
    for far in (truth + [25.0, -12.0], p0 + np.random.default_rng(2).uniform(-60, 60, p0.shape) + [110.0, 0.0]):
        p_f, ok_f = lk_fb(img0, img1, p0, cfg, far, pyr, mirror=True)
        assert np.sum(ok_f & (np.linalg.norm(p_f - truth, axis=1) > 0.1)) <= 2     # as klt-pnp's mirrored check
    raw = KltConfig(normalize_box=0)                                  # the raw-image LK mirrors the same way
    p_r, ok_r = lk_fb(img0, img1, p0, raw, guess, LkPyramids(raw.levels, raw.box), mirror=True)
    assert ok_r.mean() > 0.9 and np.abs(p_r[ok_r] - truth[ok_r]).max() < 0.1
    # without a guess the mirror changes nothing: the zero-flow search, bit for bit
    a, b = lk_fb(img0, img1, p0, cfg, pyramid=pyr), lk_fb(img0, img1, p0, cfg, pyramid=pyr, mirror=True)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])


@pytest.fixture(scope="module")
def planes():
    return box_scene(np.random.default_rng(3))


def _frame(planes, T_o_c0, rng):
    def noisy(img):
        return np.clip(img + rng.normal(0, 1.0, img.shape), 0, 255).astype(np.uint8)
    return (noisy(render(planes, PINHOLE.cameras[0], T_o_c0)),
            noisy(render(planes, PINHOLE.cameras[1], T_o_c0 @ PINHOLE.T_c0_c1)))


def _tracks(planes, T_kf_c, predict: bool):
    """The four-view tracks of a keyframe at the origin into a frame at ``T_kf_c`` (ray-cast box scene, stereo27
    rig), with the second search from the true pose's prediction or without -> (FourView, predicted p3)."""
    rng = np.random.default_rng(7)
    fv, timings = KltFourView(PINHOLE), {}
    fv.keyframe(*_frame(planes, np.eye(4), rng), timings)
    v = fv.view
    guess = predicted_left(PINHOLE, T_kf_c, v.p1, v.x1, v.p2, v.p3, MAX_DEPTH, MAX_TRI_PX)
    ids = v.ids.copy()
    out = fv.track(*_frame(planes, T_kf_c, rng), timings, (lambda i: guess[i]) if predict else None)
    return out, dict(zip(ids.tolist(), guess))


def test_a_fast_turn_is_tracked_from_the_prediction(planes):
    """A 12-degree yaw between frames (flow around 100 px, beyond the zero-flow pyramid): the second search from the
    prediction adds the tracks the zero-flow search loses, each within 2 px of the true pose's prediction (that
    prediction's own error, from keyframe stereo points triangulated on noisy images, plus the track's: a wrong
    match lands half a window or more away). What the zero-flow search holds stays bit for bit, wrong matches that
    agree both ways included (a third of them here): the ROPs' RANSAC is left to remove those."""
    T = make_T(rot_y(np.radians(12.0)), [0.05, 0.0, 0.3])
    zero, _ = _tracks(planes, T, predict=False)
    pred, guess = _tracks(planes, T, predict=True)
    g = np.array([guess[i] for i in pred.ids.tolist()])
    assert np.median(np.linalg.norm(g - pred.p1, axis=1)) > 60
    new = ~np.isin(pred.ids, zero.ids)
    assert new.sum() > len(zero) and len(pred) > 0.6 * len(guess)
    assert np.all(np.linalg.norm(pred.p3[new] - g[new], axis=1) < 2.0)
    _same_tracks(zero, pred)
    assert np.sum(np.linalg.norm(pred.p3[~new] - g[~new], axis=1) > 2.0) > 0.2 * len(zero)   # zero flow's wrong


def _same_tracks(zero, pred):
    """Every track of ``zero`` is in ``pred`` with the same four-view positions, bit for bit."""
    assert set(zero.ids.tolist()) <= set(pred.ids.tolist())
    k = np.isin(pred.ids, zero.ids)
    for name in ("ids", "p1", "p2", "p3", "p4", "ok4", "x3", "x4"):
        np.testing.assert_array_equal(getattr(pred, name)[k], getattr(zero, name))


def test_within_the_pyramids_reach_nothing_changes(planes):
    """A small step (0.1 m, 1 degree; every prediction within the 84 px reach of the zero-flow search): the tracks
    are the same with the prediction given, bit for bit, and no track is added."""
    T = make_T(rot_y(np.radians(1.0)), [0.0, 0.0, 0.1])
    zero, _ = _tracks(planes, T, predict=False)
    pred, _ = _tracks(planes, T, predict=True)
    assert len(zero) == len(pred) > 150
    _same_tracks(zero, pred)
