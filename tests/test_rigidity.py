"""The distance-invariance rigidity test (seed 001 eq. 2, vo.estimators.rigidity) on synthetic stereo scenes.

Stereo points are made from exact projections (rig: f = 460 px, b = 0.5 m, the urban-dynamic rig) with Gaussian
pixel noise inside the model's sigmas (0.1 px disparity, 0.3 px image position against 0.2 / 0.5 px in the
default RigidityConfig), so a static pair violates the 9.0 chi-square gate with probability below 0.3 %.
A static landmark is flagged only when more than 30 % of its 24 partners violate; with the partners
independent that is a binomial tail below 1e-12, so the bound stated in the tests (at most 1 % of the static
landmarks flagged) has a wide margin; it allows for the partners sharing the landmark's own noise.
"""
import numpy as np
import pytest

from rigs.geometry import inv_T, make_T, rot_y, transform_points
from rigs.geometry.pinhole import project
from rigs.presets import get_rig
from vo.errors import VoError
from vo.estimators.rigidity import RigidityConfig, refine_pose, rigid_subset, stereo_covariances
from vo.rop.estimator import RopEstimator
from vo.rop.tracks import FourView

F, B, CX, CY = 460.0, 0.5, 320.0, 200.0


def _stereo(p_c: np.ndarray, rng, s_px=0.3, s_d=0.1) -> np.ndarray:
    """Noisy stereo reconstruction of camera-frame points (N,3): project, perturb u, v, disparity, back-project."""
    u = F * p_c[:, 0] / p_c[:, 2] + CX + rng.normal(0, s_px, len(p_c))
    v = F * p_c[:, 1] / p_c[:, 2] + CY + rng.normal(0, s_px, len(p_c))
    d = F * B / p_c[:, 2] + rng.normal(0, s_d, len(p_c))
    z = F * B / d
    return np.c_[(u - CX) * z / F, (v - CY) * z / F, z]


def _rot_y(deg):
    a = np.radians(deg)
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


def _scene(seed, n_static=300, n_car=20, car_step=np.array([0.0, 0.0, 0.8])):
    """Static points 4-40 m ahead and a car box 8 m ahead; the camera moves 1 m forward and yaws 2 deg, the car
    moves by ``car_step`` (world). Returns the stereo points at both epochs (camera frames) and the car mask."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(4, 40, n_static)
    stat = np.c_[rng.uniform(-0.6, 0.6, n_static) * z, rng.uniform(-0.3, 0.4, n_static) * z, z]
    car = np.array([0.5, 0.3, 8.0]) + rng.uniform(-1, 1, (n_car, 3)) * [0.9, 0.7, 2.0]
    w_a = np.r_[stat, car]
    w_b = np.r_[stat, car + car_step]
    R, t = _rot_y(2.0), np.array([0.0, 0.0, 1.0])        # camera b in world: x_w = R x_b + t
    p_a = _stereo(w_a, rng)
    p_b = _stereo((w_b - t) @ R, rng)
    return p_a, p_b, np.r_[np.zeros(n_static, bool), np.ones(n_car, bool)]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_moving_cluster_is_flagged_and_static_points_are_not(seed):
    """A car 6-10 m ahead moving 0.8 m along the view between the epochs, holding 20 of 320 points (a moving
    minority, as among the inliers of the motion the estimators chose): >= 90 % of it is flagged (pairs whose
    direction is across the car's motion do not see it), <= 1 % of the static points."""
    p_a, p_b, car = _scene(seed)
    keep = rigid_subset(p_a, np.zeros(3), p_b, np.zeros(3), F, B, RigidityConfig(enabled=True),
                        np.random.default_rng(seed))
    assert keep[car].mean() <= 0.10
    assert (~keep[~car]).mean() <= 0.01                     # stated false-positive bound on static points


def test_a_moving_majority_of_the_near_points_wins_the_vote():
    """The test is a vote: where a rigid car holds most of the precise (near) points, the static near points
    are the ones flagged. This is why the estimators run it on the motion they already chose, not on all
    tracks (vo.estimators.rigidity)."""
    p_a, p_b, car = _scene(0, n_car=60)
    keep = rigid_subset(p_a, np.zeros(3), p_b, np.zeros(3), F, B, RigidityConfig(enabled=True),
                        np.random.default_rng(0))
    assert (~keep[~car]).sum() >= 10


def test_sliding_points_are_flagged():
    """Occlusion-edge corners: the stereo point slides 0.5 m along the far surface between the epochs."""
    rng = np.random.default_rng(7)
    p_a, p_b, car = _scene(7, n_car=0)
    slide = rng.choice(len(p_a), 30, replace=False)
    near = p_a[slide, 2] < 12          # farther, the range sigma (0.28 m per epoch at 18 m) hides a 0.5 m slide
    p_b[slide] += np.array([0.5, 0.0, 0.0])
    keep = rigid_subset(p_a, np.zeros(3), p_b, np.zeros(3), F, B, RigidityConfig(enabled=True), rng)
    assert near.sum() >= 5 and keep[slide[near]].mean() <= 0.2
    others = np.setdiff1d(np.arange(len(p_a)), slide)
    assert (~keep[others]).mean() <= 0.01


def test_motion_does_not_matter_and_a_rigid_world_keeps_everything():
    """Pure rigid motion of the whole scene (no moving cluster): nothing beyond the false-positive bound; the
    same points under a different camera motion give the same verdict rate (the test needs no pose)."""
    for seed in (3, 4):
        p_a, p_b, car = _scene(seed, n_car=0)
        keep = rigid_subset(p_a, np.zeros(3), p_b, np.zeros(3), F, B, RigidityConfig(enabled=True),
                            np.random.default_rng(seed))
        assert (~keep).mean() <= 0.01


def test_off_or_too_few_points_keeps_all():
    p_a, p_b, car = _scene(0)
    assert rigid_subset(p_a, np.zeros(3), p_b, np.zeros(3), F, B, RigidityConfig(), np.random.default_rng(0)).all()
    few = RigidityConfig(enabled=True, min_points=12)
    assert rigid_subset(p_a[-11:], np.zeros(3), p_b[-11:], np.zeros(3), F, B, few, np.random.default_rng(0)).all()


def test_covariance_follows_seed_001_eq_7():
    """Along the ray sigma_r = r^2 sigma_p / (b f); across it r sigma_px / f (plus the floor)."""
    c = RigidityConfig(disparity_sigma_px=0.2, image_sigma_px=0.5, floor_m=0.0)
    p = np.array([[0.0, 0.0, 20.0], [12.0, 0.0, 16.0]])
    S = stereo_covariances(p, np.zeros(3), F, B, c)
    for k, r in enumerate((20.0, 20.0)):
        u = p[k] / r
        assert np.sqrt(u @ S[k] @ u) == pytest.approx(r ** 2 * 0.2 / (B * F), rel=1e-12)
        w = np.cross(u, [0, 1, 0])
        assert np.sqrt(w @ S[k] @ w) == pytest.approx(r * 0.5 / F, rel=1e-12)


def test_refine_pose_recovers_exact_pose():
    rng = np.random.default_rng(1)
    p_o = np.c_[rng.uniform(-5, 5, 50), rng.uniform(-2, 2, 50), rng.uniform(5, 30, 50)]
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = _rot_y(3.0), [0.2, -0.1, -1.0]
    K = np.array([[F, 0, CX], [0, F, CY], [0, 0, 1.0]])
    q = p_o @ T[:3, :3].T + T[:3, 3]
    x = (q[:, :2] / q[:, 2:]) * F + [CX, CY]
    T0 = T.copy()
    T0[:3, 3] += [0.05, 0.02, -0.1]
    assert np.allclose(refine_pose(T0, p_o, x, K), T, atol=1e-8)


def test_config_from_option():
    assert RigidityConfig.from_option(None) == RigidityConfig()
    assert RigidityConfig.from_option(True).enabled
    assert RigidityConfig.from_option({"enabled": True, "partners": 8}).partners == 8
    with pytest.raises(VoError, match="unknown field"):
        RigidityConfig.from_option({"partner": 8})
    with pytest.raises(VoError, match="chi2_gate"):
        RigidityConfig(chi2_gate=0)


def _four_view(seed, n=200, n_slide=30):
    """Exact four-view tracks (paper002 rig, keyframe = frame 0 = o, current frame 1 m ahead, 1 deg yaw) of a
    static world; ``n_slide`` of its points slide 0.6 m sideways between the epochs (occlusion-edge corners).
    -> (rig, FourView, slid (N,) bool)."""
    rig = get_rig("paper002")
    rng = np.random.default_rng(seed)
    z = rng.uniform(5, 30, n)
    p_o = np.c_[rng.uniform(-0.5, 0.5, n) * z, rng.uniform(-0.3, 0.3, n) * z, z]
    slid = np.zeros(n, bool)
    slid[rng.choice(n, n_slide, replace=False)] = True
    world_3 = p_o + slid[:, None] * np.array([0.6, 0.0, 0.0])
    T_o_c3 = make_T(rot_y(np.radians(1.0)), np.array([0.0, 0.0, 1.0]))
    T_c1_c0 = inv_T(rig.T_c0_c1)
    px = lambda p_c, cam: project(p_c, rig.cameras[cam].K)                                   # noqa: E731
    p_c3 = transform_points(inv_T(T_o_c3), world_3)
    pts = [px(p_o, 0), px(transform_points(T_c1_c0, p_o), 1), px(p_c3, 0), px(transform_points(T_c1_c0, p_c3), 1)]
    pts = [p + rng.normal(0, 0.1, p.shape) for p in pts]                # sub-pixel matching noise
    xs = [np.linalg.solve(rig.cameras[0].K, np.c_[p, np.ones(n)].T).T[:, :2] for p in pts]
    return rig, FourView(*pts, *xs, np.ones(n, bool)), slid


@pytest.mark.parametrize("seed", [0, 1])
def test_rop_drops_the_sliding_tracks(seed):
    """``rop`` with ``rigidity`` on: the four-view tracks whose stereo point slid 0.6 m (nearer than 12 m, where
    the range sigma is below 0.13 m): >= 70 % leave the view (pairs along the view direction do not see a
    sideways slide), <= 1 % of the static tracks do; off, the view is untouched."""
    rig, view, slid = _four_view(seed)
    est = RopEstimator(rig, rigidity={"enabled": True})
    est.klt.view = view
    kept = est._rigid_tracks(view, {"track": 0.0})
    ids = {tuple(p) for p in np.round(kept.p1, 9)}
    was_kept = np.array([tuple(p) in ids for p in np.round(view.p1, 9)])
    disparity = view.p1[:, 0] - view.p2[:, 0]
    near = disparity > 460 * 0.5 / 12
    assert (slid & near).sum() >= 5 and was_kept[slid & near].mean() <= 0.3
    assert (~was_kept[~slid]).mean() <= 0.01
    assert est.klt.view is kept
    off = RopEstimator(rig)
    assert off._rigid_tracks(view, {"track": 0.0}) is view
