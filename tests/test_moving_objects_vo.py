"""Stereo VO with a large moving rigid cluster: the motion-prior consensus against exact ground truth.

Scene (exact projections, no noise): static points spread over the view at 6-40 m, and a car ahead in the
right lane (a 2 x 1.5 x 1 m box of points 8-9 m ahead) that drives at the camera's own speed, so its
landmarks, triangulated one frame earlier, say "the camera stood still". The car holds twice as many
points as the background: RANSAC's largest consensus is the car's motion (1 m off); the consensus nearest
a constant-velocity prior (5 cm, 0.3 deg off the truth, as after a gentle acceleration) is the true motion.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from rigs.geometry import inv_T, make_T, rot_x, rot_y, transform_points
from rigs.geometry.pinhole import project
from vo.errors import EstimatorError
from vo.estimators.pnp_core import PnpConfig, _own_points, candidate_motions, choose_motion, separated, solve_pnp

K = np.array([[460.0, 0, 319.5], [0, 460.0, 199.5], [0, 0, 1]])
W, H = 640, 400


def _in_view(p_c: np.ndarray) -> np.ndarray:
    uv = project(p_c, K)
    return (p_c[:, 2] > 0.5) & (uv[:, 0] >= 0) & (uv[:, 0] < W) & (uv[:, 1] >= 0) & (uv[:, 1] < H)


def _scene(rng: np.random.Generator, n_static: int = 60, n_car: int = 120):
    """-> (p_o landmarks (frame 0 = o), x pixels in frame 1, T_o_c1 true, is_car (N,) bool)."""
    static = []
    while len(static) < n_static:
        p = np.c_[rng.uniform(-20, 20, 400), rng.uniform(-6, 3, 400), rng.uniform(6, 40, 400)]
        static.extend(p[_in_view(p) & _in_view(p - [0, 0, 1.2])])
    static = np.array(static[:n_static])
    car = np.c_[rng.uniform(1.0, 3.0, n_car), rng.uniform(-0.5, 1.0, n_car), rng.uniform(8.0, 9.0, n_car)]
    T_o_c1 = make_T(rot_y(np.radians(0.8)) @ rot_x(np.radians(0.2)), np.array([0.05, 0.0, 1.0]))
    T_o_car1 = make_T(np.eye(3), T_o_c1[:3, 3])           # the car moved with the camera (same velocity)
    p_o = np.vstack([static, car])
    p_world_1 = np.vstack([static, transform_points(T_o_car1, car)])
    x = project(transform_points(inv_T(T_o_c1), p_world_1), K)
    return p_o, x, T_o_c1, np.r_[np.zeros(n_static, bool), np.ones(n_car, bool)]


def _prior(T_o_c1: np.ndarray) -> np.ndarray:
    """A constant-velocity prediction: 5 cm and 0.3 deg off the true pose."""
    return T_o_c1 @ make_T(rot_y(np.radians(0.3)), np.array([0.03, -0.02, 0.035]))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_prior_consensus_picks_the_static_world_where_largest_picks_the_car(seed):
    p_o, x, T_o_c1, is_car = _scene(np.random.default_rng(seed))
    cfg = PnpConfig()

    T_old, inl_old = solve_pnp(p_o, x, K, PnpConfig(consensus="largest"), T_o_c0_prior=_prior(T_o_c1))
    assert np.mean(is_car[inl_old]) > 0.9                          # the old consensus: the car
    assert np.linalg.norm(T_old[:3, 3] - T_o_c1[:3, 3]) > 0.8      # ... i.e. "the camera stood still"

    T_new, inl_new = solve_pnp(p_o, x, K, cfg, T_o_c0_prior=_prior(T_o_c1))
    # exact projections: the static model is exact up to LM's convergence
    assert np.linalg.norm(T_new[:3, 3] - T_o_c1[:3, 3]) < 1e-6
    assert np.degrees(np.arccos(np.clip((np.trace(T_new[:3, :3].T @ T_o_c1[:3, :3]) - 1) / 2, -1, 1))) < 1e-6
    assert np.all(inl_new[~is_car]) and not np.any(inl_new[is_car])


def test_two_candidate_motions_are_the_car_then_the_world():
    p_o, x, T_o_c1, is_car = _scene(np.random.default_rng(3))
    models = candidate_motions(p_o, x, K, PnpConfig())
    assert len(models) == 2
    (T_car, inl_car), (T_static, inl_static) = models
    # far static points fit any small translation: they are inliers of both motions
    assert inl_car[is_car].all() and np.array_equal(inl_static, ~is_car)
    assert np.linalg.norm(inv_T(T_static)[:3, 3] - T_o_c1[:3, 3]) < 1e-6
    # the car's motion: the camera "stood still" (its RANSAC inliers include far static points within the
    # 2 px gate, which pull the LM fit by ~0.1 m; the true step is 1 m)
    assert np.linalg.norm(inv_T(T_car)[:3, 3]) < 0.25


def test_one_rigid_world_is_solved_as_before():
    """No second cluster: both consensus rules give the same exact pose, and without a prior the rule
    is RANSAC's largest consensus."""
    p_o, x, T_o_c1, is_car = _scene(np.random.default_rng(4), n_car=0)
    for cfg, prior in ((PnpConfig(), _prior(T_o_c1)), (PnpConfig(consensus="largest"), None), (PnpConfig(), None)):
        T, inl = solve_pnp(p_o, x, K, cfg, T_o_c0_prior=prior)
        assert np.linalg.norm(T[:3, 3] - T_o_c1[:3, 3]) < 1e-6 and inl.all()


def test_small_cluster_does_not_compete():
    """A second motion below ``min_model_fraction`` of the landmarks is never a candidate: a prior next to
    it cannot pull the solution away from the world."""
    p_o, x, T_o_c1, is_car = _scene(np.random.default_rng(5), n_static=100, n_car=8)
    T, inl = solve_pnp(p_o, x, K, PnpConfig(), T_o_c0_prior=make_T(np.eye(3), np.zeros(3)))
    assert np.linalg.norm(T[:3, 3] - T_o_c1[:3, 3]) < 1e-6 and not inl[is_car].any()


def test_bad_consensus_option_is_one_line_error():
    with pytest.raises(EstimatorError, match=r"pnp\.consensus"):
        PnpConfig(consensus="vote")
    with pytest.raises(EstimatorError, match=r"klt-pnp\.pnp_config\.foo"):
        PnpConfig.from_option({"foo": 1}, "klt-pnp.pnp_config")


def test_rop_track_filter_keeps_the_static_tracks():
    """``rop``'s front-end filter (:mod:`vo.rop.moving`) on exact four-view tracks of the same scene seen by the
    paper002 stereo rig: the tracks of the car are dropped, every static one is kept; with a prior at the car's
    motion the car would be kept (the prior decides, not the cluster size)."""
    from rigs.presets import get_rig
    from vo.rop.moving import filter_tracks
    from vo.rop.tracks import FourView

    rig = get_rig("paper002")
    K0 = rig.cameras[0].K
    p_o, _, T_o_c3, is_car = _scene(np.random.default_rng(6))
    T_c0_c1 = rig.T_c0_c1
    world_3 = np.vstack([p_o[~is_car], transform_points(make_T(np.eye(3), T_o_c3[:3, 3]), p_o[is_car])])
    px = lambda p_c, cam: project(p_c, rig.cameras[cam].K)                                   # noqa: E731
    p1, p2 = px(p_o, 0), px(transform_points(inv_T(T_c0_c1), p_o), 1)
    p_c3 = transform_points(inv_T(T_o_c3), world_3)
    p3, p4 = px(p_c3, 0), px(transform_points(inv_T(T_c0_c1), p_c3), 1)
    n = len(p_o)
    xs = [np.linalg.solve(K0, np.c_[p, np.ones(n)].T).T[:, :2] for p in (p1, p2, p3, p4)]
    view = FourView(p1, p2, p3, p4, *xs, np.ones(n, bool))

    keep = filter_tracks(view, rig, _prior(T_o_c3), PnpConfig()).keep
    assert keep is not None and np.array_equal(keep, ~is_car)
    keep_car = filter_tracks(view, rig, make_T(np.eye(3), np.zeros(3)), PnpConfig()).keep
    assert keep_car[is_car].all() and keep_car.sum() < n
    static_only = view.subset(~is_car)
    assert filter_tracks(static_only, rig, _prior(T_o_c3), PnpConfig()).keep is None   # one motion: untouched


def test_rop_moving_objects_option():
    from vo.rop.rop_config import RopConfig
    assert RopConfig.from_options({"moving_objects": "none"}).moving_objects == "none"
    with pytest.raises(EstimatorError, match=r"rop\.moving_objects"):
        RopConfig.from_options({"moving_objects": "maybe"})


def _box(rng: np.random.Generator, n: int, lo, hi) -> np.ndarray:
    """``n`` points uniform in the box ``lo``-``hi`` (camera frame of frame 0) that frame 0 sees."""
    out = []
    while len(out) < n:
        p = rng.uniform(lo, hi, (400, 3))
        out.extend(p[_in_view(p)])
    return np.array(out[:n])


def _stop_scene(rng: np.random.Generator):
    """The vehicle creeps at a stop (2 cm, 0.05 deg) while the car ahead pulls away (1.5 m): 20 near static
    points (6-20 m), 100 far ones (100-300 m) and 70 on the car 6-7.5 m ahead. The far points fit the car's
    motion too (they barely move when the camera 'backs off' 1.5 m), so RANSAC's largest consensus is the car
    plus most of the far points, and more than half of its inliers are shared with the standing-still motion.
    -> (p_o, x in frame 1, T_o_c1 true, is_car)."""
    near, far = _box(rng, 20, [-12, -3, 6], [12, 2, 20]), _box(rng, 100, [-150, -30, 100], [150, 10, 300])
    car = np.c_[rng.uniform(1.5, 3.0, 70), rng.uniform(-0.5, 1.0, 70), rng.uniform(6.0, 7.5, 70)]
    T_o_c1 = make_T(rot_y(np.radians(0.05)), np.array([0.0, 0.0, 0.02]))
    p_o = np.vstack([near, far, car])
    x = project(transform_points(inv_T(T_o_c1), np.vstack([near, far, car + [0.0, 0.0, 1.5]])), K)
    return p_o, x, T_o_c1, np.r_[np.zeros(120, bool), np.ones(70, bool)]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_motions_sharing_most_inliers_are_told_apart_by_the_points_one_leaves_off(seed):
    """Crossing / departing traffic at a stop: the car's candidate shares more than half its inliers (the far
    points) with the standing-still one, yet its own points lie > ``separation_px`` off the other: two
    motions; the one nearest the prior (standing still) wins, exactly, with exactly the static points."""
    from vo.estimators.pnp_core import separated
    p_o, x, T_o_c1, is_car = _stop_scene(np.random.default_rng(seed))
    cfg = PnpConfig()
    (T_car, inl_car), static = candidate_motions(p_o, x, K, cfg)[:2]
    assert np.linalg.norm(inv_T(T_car)[:3, 3] - T_o_c1[:3, 3]) > 1.0 and inl_car[is_car].all()
    assert (inl_car & static[1]).sum() > 0.5 * inl_car.sum()          # inlier overlap: "one motion"
    assert separated((T_car, inl_car), static, p_o, x, K, cfg, need=0.1 * len(p_o))

    prior = T_o_c1 @ make_T(np.eye(3), np.array([0.01, 0.0, -0.02]))   # constant velocity at the stop
    T_largest, _ = solve_pnp(p_o, x, K, PnpConfig(consensus="largest"), T_o_c0_prior=prior)
    assert np.linalg.norm(T_largest[:3, 3] - T_o_c1[:3, 3]) > 1.0
    T, inl = solve_pnp(p_o, x, K, cfg, T_o_c0_prior=prior)
    assert np.linalg.norm(T[:3, 3] - T_o_c1[:3, 3]) < 1e-6 and np.array_equal(inl, ~is_car)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_landmarks_of_an_older_keyframe_are_not_a_second_motion(seed):
    """One static world whose landmarks come from two keyframes, the older one's pose 10 cm / 0.1 deg off
    (a typical accumulated VO error), 0.3 px pixel noise: RANSAC leaves part of that third of the landmarks
    as a second cluster a few px off, which a 2 px separation (the inlier gate) calls a second motion; with
    ``separation_px`` (4 px) it is one motion and the result is RANSAC's fit, exactly as with the largest
    consensus."""
    import dataclasses
    from vo.estimators.pnp_core import choose_motion
    rng = np.random.default_rng(seed)
    p_true = _box(rng, 150, [-25, -6, 6], [25, 3, 60])
    T_o_c1 = make_T(rot_y(np.radians(0.8)) @ rot_x(np.radians(0.2)), np.array([0.05, 0.0, 1.0]))
    x = project(transform_points(inv_T(T_o_c1), p_true), K) + rng.normal(0.0, 0.3, (150, 2))
    p_o = p_true.copy()
    p_o[:50] = transform_points(make_T(rot_y(np.radians(0.1)), np.array([0.1, 0.0, 0.05])), p_true[:50])
    cfg, prior = PnpConfig(), _prior(T_o_c1)
    assert len(candidate_motions(p_o, x, K, cfg)) == 2
    assert choose_motion(p_o, x, K, dataclasses.replace(cfg, separation_px=2.0), prior)[2]   # split at 2 px
    T_c0_o, _, competing = choose_motion(p_o, x, K, cfg, prior)
    T_largest, _ = solve_pnp(p_o, x, K, PnpConfig(consensus="largest"))
    assert not competing and np.allclose(inv_T(T_c0_o), T_largest, atol=1e-12)



def _rop_exact_view(seed: int):
    """Exact four-view tracks of the two-motion scene (:func:`_scene`, keyframe = frame 0 = ``o``) seen by the
    paper002 rig -> (rig, FourView, T_o_c3 true, is_car)."""
    from rigs.presets import get_rig
    from vo.rop.tracks import FourView
    rig = get_rig("paper002")
    p_o, _, T_o_c3, is_car = _scene(np.random.default_rng(seed))
    world_3 = np.vstack([p_o[~is_car], transform_points(make_T(np.eye(3), T_o_c3[:3, 3]), p_o[is_car])])
    px = lambda p_c, cam: project(p_c, rig.cameras[cam].K)                                   # noqa: E731
    T_c1_c0 = inv_T(rig.T_c0_c1)
    p_c3 = transform_points(inv_T(T_o_c3), world_3)
    pts = (px(p_o, 0), px(transform_points(T_c1_c0, p_o), 1), px(p_c3, 0), px(transform_points(T_c1_c0, p_c3), 1))
    xs = [np.linalg.solve(rig.cameras[0].K, np.c_[p, np.ones(len(p_o))].T).T[:, :2] for p in pts]
    return rig, FourView(*pts, *xs, np.ones(len(p_o), bool)), T_o_c3, is_car


@pytest.mark.parametrize("seed", [0, 1])
def test_rop_prior_from_the_filter_pnp_survives_a_rop_step_pulled_onto_the_car(seed):
    """``rop`` after one ROP step pulled onto the car (its constant-velocity extrapolation says "standing
    still", the car's motion): the prediction from the track filter's own PnP poses (``moving_prior="pnp"``)
    still selects exactly the static tracks and the filter's pose is the true one (exact projections: 1e-6 m);
    the prediction from the estimator's poses (``"velocity"``) selects the car. A ROP step 0.36 m off that PnP
    pose fails the frame (``moving_step_gate_m``), the true one does not; the failed frame takes the PnP pose
    (the true pose, where constant-velocity coasting would stay 1 m behind)."""
    from vo.rop.estimator import MIN_COAST_PNP_INLIERS, RopEstimator
    from vo.rop.moving import filter_tracks
    rig, view, T_o_c3, is_car = _rop_exact_view(seed)
    est = RopEstimator(rig)
    c, pnp_config = est.config, est.track_filter_config
    priors = {"pnp": _prior(T_o_c3),               # the filter's PnP step: 5 cm, 0.3 deg off
              "velocity": np.eye(4)}               # the ROP step said "standing still" (the car)
    f = filter_tracks(view, rig, priors["pnp"], pnp_config)
    assert np.array_equal(f.keep, ~is_car)
    T_pnp = f.frame_pose(True, c.moving_prior_gate_m, MIN_COAST_PNP_INLIERS)
    assert T_pnp is not None and np.linalg.norm(T_pnp[:3, 3] - T_o_c3[:3, 3]) < 1e-6
    assert not f.step_miss(T_o_c3, T_pnp, c.moving_step_gate_m)
    assert f.step_miss(T_o_c3 @ make_T(np.eye(3), np.array([0.0, 0.0, 0.36])), T_pnp, c.moving_step_gate_m)
    car = filter_tracks(view, rig, priors["velocity"], pnp_config)
    assert car.keep is not None and car.keep.any() and not car.keep[~is_car].any()      # the car's tracks only


@pytest.mark.parametrize("seed", [0, 1])
def test_rop_step_cross_check_needs_competing_motions(seed):
    """The ROP step cross-check guards against a step pulled by a moving object's tracks, which the track
    filter sees as a second rigid motion. On the static tracks alone (one motion, ``keep`` None) a ROP step
    0.36 m off the filter's PnP pose stands (ROP and PnP then fit the same motion and differ only where stereo
    depth and four-view geometry disagree in scale, e.g. under a calibration error); with the car's tracks
    present the same step fails the frame."""
    from vo.rop.estimator import MIN_COAST_PNP_INLIERS, RopEstimator
    from vo.rop.moving import filter_tracks
    rig, view, T_o_c3, is_car = _rop_exact_view(seed)
    est = RopEstimator(rig)
    c = est.config
    off = T_o_c3 @ make_T(np.eye(3), np.array([0.0, 0.0, 0.36]))
    for v, competing in ((view.subset(~is_car), False), (view, True)):
        f = filter_tracks(v, rig, _prior(T_o_c3), est.track_filter_config)
        assert (f.keep is not None) == competing
        T_pnp = f.frame_pose(True, c.moving_prior_gate_m, MIN_COAST_PNP_INLIERS)
        assert np.linalg.norm(T_pnp[:3, 3] - T_o_c3[:3, 3]) < 1e-6
        assert bool(f.step_miss(off, T_pnp, c.moving_step_gate_m)) == competing
        assert not f.step_miss(T_o_c3, T_pnp, c.moving_step_gate_m)


def test_a_candidate_whose_points_other_motions_explain_better_is_not_chosen():
    """Recorded inputs of `rop`'s track filter on a static campus scene with an 11-cm stereo baseline (20 Hz, frame
    181 of a generated route; ``tests/data/short_baseline_motions.npz``: the keyframe's stereo points, the current
    undistorted pixels, the prior and the true motion). RANSAC's leftovers give a candidate 8 mm from the prior that
    is "separated" from RANSAC's fit yet has fewer points of its own than a motion needs (10 % of the tracks): it is
    a refit of the static world's motion, not a moving object, and leaves the choice: the rest are one rigid motion,
    so the result is RANSAC's fit (as without a prior), which keeps the scene's tracks (>= 80 %) and lies within 6 mm
    of the true camera position (measured 5.7 mm; the candidate left out: 11 mm)."""
    d = np.load(Path(__file__).parent / "data" / "short_baseline_motions.npz")
    p, x, K, prior = d["p_kf"], d["x_undist"], d["K"], d["T_kf_c_prior"]
    cfg = PnpConfig(ransac_reproj_px=2.0, min_model_fraction=0.1)
    need = 0.1 * len(p)
    cv2.setRNGSeed(0)
    models = [m for m in candidate_motions(p, x, K, cfg) if m[1].sum() >= cfg.min_pnp_inliers]
    dist = [np.linalg.norm(inv_T(T)[:3, 3] - prior[:3, 3]) for T, _ in models]
    near = models[int(np.argmin(dist))]
    others = [m for m in models if m is not near and separated(near, m, p, x, K, cfg, need)]
    assert others and _own_points(near, others, p, x, K).sum() < need       # the case the rule is for
    cv2.setRNGSeed(0)
    T_c_kf, inl, competing = choose_motion(p, x, K, cfg, prior)
    assert not competing and inl.sum() >= 0.8 * len(p)
    np.testing.assert_array_equal(T_c_kf, models[0][0])
    assert np.linalg.norm(inv_T(T_c_kf)[:3, 3] - d["T_kf_c_true"][:3, 3]) < 0.006
    assert np.linalg.norm(inv_T(near[0])[:3, 3] - d["T_kf_c_true"][:3, 3]) > 0.01
