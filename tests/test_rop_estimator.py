"""RopEstimator end to end on a ray-cast textured room (no MuJoCo): accuracy, failure handling."""
import cv2
import numpy as np
import pytest

from rigs.presets import get_rig
from vo.dataset.types import StereoFrame
from vo.errors import EstimatorError
from vo.estimators.base import STATUSES
from rigs.geometry import make_T, rot_y, rotation_angle, skew
from vo.rop.estimator import RopEstimator, propagate_cov

RIG = get_rig("cart27")                    # 720x480, 0.2857 m baseline, seed 000 distortion
PLANES = [(2, 5.0), (2, -4.0), (0, -1.8), (0, 1.8), (1, 1.0), (1, -1.4)]   # room walls in O (axis, value)


def _texture(seed=0, size=512):
    """Blurred random blobs: corner-rich, non-repeating within a wall."""
    rng = np.random.default_rng(seed)
    tex = cv2.GaussianBlur(rng.uniform(0, 255, (size, size)).astype(np.float32), (0, 0), 1.5)
    return cv2.normalize(tex, None, 0, 255, cv2.NORM_MINMAX)


TEX = _texture()


def render(cam, T_o_c):
    """(H,W) uint8 image of the room seen by ``cam`` at pose ``T_o_c`` (distortion included)."""
    u, v = np.meshgrid(np.arange(cam.width, dtype=np.float64), np.arange(cam.height, dtype=np.float64))
    px = np.stack([u.ravel(), v.ravel()], axis=1).reshape(-1, 1, 2)
    x = cv2.undistortPoints(px, cam.K, cam.dist_coeffs).reshape(-1, 2)
    d = np.c_[x, np.ones(len(x))] @ T_o_c[:3, :3].T
    c = T_o_c[:3, 3]
    best = np.full(len(d), np.inf)
    tu, tv = np.zeros(len(d)), np.zeros(len(d))
    for k, (axis, val) in enumerate(PLANES):
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (val - c[axis]) / d[:, axis]
        hit = (t > 0) & (t < best)
        P = c + t[hit, None] * d[hit]
        a, b = [i for i in range(3) if i != axis]
        best[hit] = t[hit]
        tu[hit], tv[hit] = P[:, a] * 150 + 97 * k, P[:, b] * 150 + 31 * k   # 150 texture px per metre
    img = cv2.remap(TEX, tu.reshape(u.shape).astype(np.float32), tv.reshape(u.shape).astype(np.float32),
                    cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
    return np.clip(img, 0, 255).astype(np.uint8)


def true_poses(n, step=0.3, yaw_deg=0.8):
    return [make_T(rot_y(np.radians(yaw_deg * k)), [0.02 * k, 0.0, step * k]) for k in range(n)]


def frames(poses):
    T_c0_c1 = RIG.T_c0_c1
    for k, T in enumerate(poses):
        yield StereoFrame(k, k * 100_000_000, render(RIG.cameras[0], T), render(RIG.cameras[1], T @ T_c0_c1))


def test_room_sequence_tracks_truth_klt():
    poses = true_poses(5)
    est = RopEstimator(RIG, frontend="klt")
    results = [est.process(f) for f in frames(poses)]
    assert results[0].status == "init"
    assert all(r.status in ("ok", "keyframe") for r in results[1:]), [r.message for r in results]
    assert "keyframe" in [r.status for r in results]       # 0.3 m steps, keyframe every 2 x 0.2857 m
    T_end, T_true = results[-1].T_o_c0, poses[-1]
    path = 4 * 0.3
    # KLT ROPs here are within ~0.4 deg (direction) / 0.04 deg (rotation); measured 0.3 % drift and
    # 0.01 deg after 4 steps - the 2 % / 0.3 deg bounds leave room for RANSAC variation
    assert np.linalg.norm(T_end[:3, 3] - T_true[:3, 3]) < 0.02 * path
    assert np.degrees(rotation_angle(T_end[:3, :3].T @ T_true[:3, :3])) < 0.3
    assert all(set(r.timings_ms) >= {"track", "stereo", "essential", "initial", "adjust", "total"} for r in results[1:])
    traces = [np.trace(r.cov) for r in results]
    assert np.all(np.isfinite(traces)) and traces[-1] > traces[1] > 0     # uncertainty grows along the chain


def test_room_sequence_orb_error_within_its_covariance():
    """ORB keypoints (pyramid-quantised) give ~1-4 deg direction errors on forward motion here; the
    a-posteriori covariance must own up to it: position error within 3 sigma (trace). (The default
    "propagated" covariance does not: 28 mm error vs 6 mm sigma - the quantisation is not in the
    Sampson residuals of each ROP, only in their disagreement.)"""
    poses = true_poses(3)
    est = RopEstimator(RIG, frontend="orb", cov="apost")
    results = [est.process(f) for f in frames(poses)]
    assert results[0].status == "init" and all(r.status in ("ok", "keyframe") for r in results[1:])
    r = results[-1]
    err = np.linalg.norm(r.T_o_c0[:3, 3] - poses[-1][:3, 3])
    assert np.all(np.isfinite(r.cov)) and err < 3 * np.sqrt(np.trace(r.cov[3:, 3:]))


def test_blank_images_never_nan_and_reinitialise():
    est = RopEstimator(RIG, frontend="orb")
    blank = np.full((480, 720), 128, np.uint8)
    poses = true_poses(2)
    good = list(frames(poses))
    r0 = est.process(good[0])
    r1 = est.process(StereoFrame(1, 1, blank, blank))
    assert r1.status == "few_features" and "re-initialising" in r1.message
    assert np.all(np.isfinite(r1.T_o_c0)) and np.all(np.isfinite(r1.cov))
    np.testing.assert_array_equal(r1.T_o_c0, r0.T_o_c0)
    r2 = est.process(StereoFrame(2, 2, blank, blank))
    assert r2.status in STATUSES and np.all(np.isfinite(r2.T_o_c0))
    r3 = est.process(good[1])                   # previous frame blank: still few features
    assert r3.status == "few_features" and np.all(np.isfinite(r3.T_o_c0))


def test_options_are_validated():
    with pytest.raises(EstimatorError, match="valid: klt, orb, sift"):
        RopEstimator(RIG, frontend="surf")
    with pytest.raises(EstimatorError, match="unknown option"):
        RopEstimator(RIG, frontends="orb")
    with pytest.raises(EstimatorError, match="rop.rop_loss: 'huber'; valid: gate, cauchy, tukey"):
        RopEstimator(RIG, rop_loss="huber")


def test_propagate_cov_matches_monte_carlo_linearisation():
    """First-order chaining formula against finite differences of the composition."""
    from rigs.geometry import so3_exp, so3_log
    rng = np.random.default_rng(0)
    T1 = make_T(so3_exp(rng.normal(0, 0.3, 3)), rng.normal(0, 2, 3))
    T2 = make_T(so3_exp(rng.normal(0, 0.1, 3)), rng.normal(0, 1, 3))

    def perturb(T, d):
        return make_T(so3_exp(d[:3]) @ T[:3, :3], T[:3, 3] + d[3:])

    def err(T, T_ref):
        return np.r_[so3_log(T[:3, :3] @ T_ref[:3, :3].T), T[:3, 3] - T_ref[:3, 3]]

    T12 = T1 @ T2
    eps = 1e-6
    J_old = np.stack([err(perturb(T1, eps * e) @ T2, T12) / eps for e in np.eye(6)], axis=1)
    J_step = np.stack([err(T1 @ perturb(T2, eps * e), T12) / eps for e in np.eye(6)], axis=1)
    C1, C2 = np.diag(rng.uniform(1, 2, 6)), np.diag(rng.uniform(1, 2, 6))
    expected = J_old @ C1 @ J_old.T + J_step @ C2 @ J_step.T
    # finite-difference Jacobians are exact to O(eps) = 1e-6 relative
    np.testing.assert_allclose(propagate_cov(C1, T1, T2, C2), expected, rtol=1e-4, atol=1e-4)
    assert skew([1, 2, 3]).shape == (3, 3)
