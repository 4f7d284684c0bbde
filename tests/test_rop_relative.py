"""estimate_rop: essential-matrix ROP from distorted, noisy pixel matches with outliers."""
import cv2
import numpy as np

from rigs.geometry import inv_T, make_T, rotation_angle, so3_exp, transform_points
from vo.rop.relative import estimate_rop, rop_from_opencv

K = np.array([[504.3, 0, 360.6], [0, 504.3, 239.8], [0, 0, 1.0]])
DIST = np.array([0.0176, -0.0356, -0.0006, -0.0005, 0.0507])   # seed 000 Table 2 (cart27)


def project(p_c, K_, dist):
    """(N,3) points in an OpenCV camera frame -> (N,2) distorted pixels."""
    px, _ = cv2.projectPoints(p_c.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K_, dist)
    return px.reshape(-1, 2)


def scene(rng, T_i_j, n=300, outlier_frac=0.2, noise_px=0.3):
    """Points 3-15 m ahead inside both 720x480 images; the first ``outlier_frac`` matches random."""
    p_i = np.zeros((0, 3))
    while len(p_i) < n:
        uv1 = np.c_[rng.uniform(10, 710, n), rng.uniform(10, 470, n), np.ones(n)]
        cand = (uv1 @ np.linalg.inv(K).T) * rng.uniform(3, 15, (n, 1))
        q = transform_points(inv_T(T_i_j), cand)
        uv_j = q[:, :2] / q[:, 2:] * K[0, 0] + K[:2, 2]
        keep = (q[:, 2] > 1) & np.all((uv_j > 10) & (uv_j < [710, 470]), axis=1)
        p_i = np.vstack([p_i, cand[keep]])
    p_i = p_i[:n]
    p_j = transform_points(inv_T(T_i_j), p_i)
    u_i = project(p_i, K, DIST) + rng.normal(0, noise_px, (n, 2))
    u_j = project(p_j, K, DIST) + rng.normal(0, noise_px, (n, 2))
    n_out = int(outlier_frac * n)
    u_j[:n_out] = np.c_[rng.uniform(0, 720, n_out), rng.uniform(0, 480, n_out)]
    is_outlier = np.zeros(n, bool)
    is_outlier[:n_out] = True
    return u_i, u_j, is_outlier


def test_opencv_convention_conversion():
    """recoverPose's (R, t) maps x_j = R x_i + t; rop_from_opencv must return T_i_j's R and direction."""
    T_i_j = make_T(so3_exp([0.01, -0.02, 0.03]), [0.1, -0.05, 0.8])
    T_j_i = inv_T(T_i_j)
    R, rhat = rop_from_opencv(T_j_i[:3, :3], 3.0 * T_j_i[:3, 3])     # any positive scale
    np.testing.assert_allclose(R, T_i_j[:3, :3], atol=1e-12)
    np.testing.assert_allclose(rhat, T_i_j[:3, 3] / np.linalg.norm(T_i_j[:3, 3]), atol=1e-12)


def test_estimate_rop_recovers_motion_and_flags_outliers():
    rng = np.random.default_rng(0)
    for trial in range(3):
        T_i_j = make_T(so3_exp(rng.normal(0, 0.03, 3)), [rng.normal(0, 0.1), rng.normal(0, 0.05), 0.7])
        u_i, u_j, is_outlier = scene(rng, T_i_j)
        rop = estimate_rop(u_i, u_j, K, DIST, K, DIST, seed=trial, ransac_threshold_px=1.0)
        assert rop.ok
        # 0.3 px noise over ~240 inliers at f = 504 px: rotation error ~ 1e-3 deg, direction ~ 0.1 deg
        assert np.degrees(rotation_angle(rop.R_i_j.T @ T_i_j[:3, :3])) < 0.05
        rhat_true = T_i_j[:3, 3] / np.linalg.norm(T_i_j[:3, 3])
        assert np.degrees(np.arccos(np.clip(rop.rhat_i_j @ rhat_true, -1, 1))) < 0.5
        # random outliers lie on the epipolar line within 1 px by chance only (~1 % of them)
        assert np.mean(~rop.inlier_mask[is_outlier]) > 0.9
        assert np.mean(rop.inlier_mask[~is_outlier]) > 0.9      # 1 px vs 0.3 px noise: ~all kept
        assert rop.n_inliers == int(rop.inlier_mask.sum())


def test_estimate_rop_is_reproducible_with_seed():
    rng = np.random.default_rng(1)
    T_i_j = make_T(so3_exp([0.0, 0.02, 0.0]), [0.05, 0.0, 0.5])
    u_i, u_j, _ = scene(rng, T_i_j, outlier_frac=0.4)
    a = estimate_rop(u_i, u_j, K, DIST, K, DIST, seed=5)
    b = estimate_rop(u_i, u_j, K, DIST, K, DIST, seed=5)
    np.testing.assert_array_equal(a.R_i_j, b.R_i_j)
    np.testing.assert_array_equal(a.inlier_mask, b.inlier_mask)


def test_degenerate_input_is_not_ok_and_finite():
    rng = np.random.default_rng(2)
    few = rng.uniform(0, 400, (4, 2))
    for u_i, u_j in [(few, few), (np.zeros((0, 2)), np.zeros((0, 2))), (few, few[:3]),
                     (np.tile([[100.0, 100.0]], (50, 1)), np.tile([[120.0, 90.0]], (50, 1)))]:
        rop = estimate_rop(u_i, u_j, K, DIST, K, DIST)
        assert not rop.ok and rop.message
        assert np.all(np.isfinite(rop.R_i_j)) and np.all(np.isfinite(rop.rhat_i_j))


def test_cauchy_loss_recovers_motion_like_the_gate():
    rng = np.random.default_rng(0)
    T_i_j = make_T(so3_exp(rng.normal(0, 0.03, 3)), [rng.normal(0, 0.1), rng.normal(0, 0.05), 0.7])
    u_i, u_j, is_outlier = scene(rng, T_i_j)
    rop = estimate_rop(u_i, u_j, K, DIST, K, DIST, seed=0, ransac_threshold_px=1.0, loss="cauchy")
    assert rop.ok and rop.cov6 is not None
    assert np.degrees(rotation_angle(rop.R_i_j.T @ T_i_j[:3, :3])) < 0.05
    rhat_true = T_i_j[:3, 3] / np.linalg.norm(T_i_j[:3, 3])
    assert np.degrees(np.arccos(np.clip(rop.rhat_i_j @ rhat_true, -1, 1))) < 0.5
    assert np.mean(~rop.inlier_mask[is_outlier]) > 0.9


def test_cauchy_loss_removes_the_bistable_inlier_gate():
    """Recorded case (campus-short, 3x, 11 px LK; keyframe step 5, ROP 2-3; two runs whose images differ
    only by grey-level noise 0.25): 316 of ~330 tracks are common, their points differ by 0.008 px
    (median). With the hard gate the two runs' ROPs land on two self-consistent inlier sets 0.79 deg
    apart in direction (12 sigma); the Cauchy fit moves by < 0.1 deg (measured 0.03)."""
    from pathlib import Path
    from vo.rop.relative import estimate_rop_normalized
    d = np.load(Path(__file__).parent / "data" / "rop23_bistable.npz")
    prior = (d["prior_R"], d["prior_rhat"])

    def direction_change(loss):
        a, b = (estimate_rop_normalized(d[f"xi_{k}"], d[f"xj_{k}"], 504.0, 0, 1.0, 0.999, max_iters=200,
                                        prior=prior, loss=loss) for k in "ab")
        assert a.ok and b.ok
        return np.degrees(np.arccos(np.clip(a.rhat_i_j @ b.rhat_i_j, -1, 1)))

    assert direction_change("gate") > 0.5
    assert direction_change("cauchy") < 0.1


def test_unknown_loss_is_rejected():
    import pytest
    from vo.errors import VoError
    rng = np.random.default_rng(0)
    u_i, u_j, _ = scene(rng, make_T(np.eye(3), [0.1, 0, 0.7]), n=50)
    with pytest.raises(VoError, match="loss"):
        estimate_rop(u_i, u_j, K, DIST, K, DIST, loss="huber")
