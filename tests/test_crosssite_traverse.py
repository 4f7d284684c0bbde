"""Traverse-level helpers of the cross-site localizer: the leg covariance of the dead-reckoning prior."""
import gtsam
import numpy as np

from rigs.geometry import make_T, rot_z
from vo.crosssite.localizer import relative_prior_cov
from vo.crosssite.types import Site, StereoCal, StereoPair


def _site(index, T, C):
    img = np.zeros((32, 32), np.uint8)
    cal = StereoCal(np.array([[30.0, 0, 16], [0, 30.0, 16], [0, 0, 1]]), make_T(np.eye(3), [0.27, 0, 0]), 32, 32)
    return Site(index, index, (StereoPair(img, img, np.eye(4)),), cal, T, C)


def test_relative_prior_cov_recovers_an_independent_leg():
    """C_k = Ad C_{k-1} Ad^T + Q (right perturbation carried through the drive D, plus an independent
    leg noise Q): the function returns Q exactly (to rounding)."""
    rng = np.random.default_rng(4)
    A = rng.standard_normal((6, 6))
    C_prev = 0.01 * A @ A.T + 1e-4 * np.eye(6)
    B = rng.standard_normal((6, 6))
    Q = 0.02 * B @ B.T + 1e-5 * np.eye(6)
    T_prev = make_T(rot_z(0.4), [3.0, -2.0, 0.1])
    D = make_T(rot_z(-0.3), [8.0, 1.0, 0.2])
    Ad = gtsam.Pose3(D).inverse().AdjointMap()
    C_cur = Ad @ C_prev @ Ad.T + Q
    out = relative_prior_cov(_site(0, T_prev, C_prev), _site(1, T_prev @ D, 0.5 * (C_cur + C_cur.T)))
    assert np.allclose(out, Q, atol=1e-10)


def test_relative_prior_cov_is_positive_definite_when_the_difference_is_not():
    """A current covariance smaller than the carried previous one (correlated legs): clipped, never
    indefinite."""
    C = np.diag([1e-4] * 3 + [1.0] * 3)
    out = relative_prior_cov(_site(0, np.eye(4), C), _site(1, make_T(np.eye(3), [5.0, 0, 0]), 0.5 * C))
    assert np.linalg.eigvalsh(out).min() > 0 and np.all(np.isfinite(out))


def test_truth_scoring_accepts_exact_ties_and_rejects_moved_ones():
    """``truth.true_ties``: ties built exactly from world points (current stereo column from the true
    depth) are all true; moving the previous pixel by 10 px makes them false (tolerance 4 px)."""
    from vo.crosssite.regions import project
    from vo.crosssite.ties import TieSet
    from vo.crosssite.truth import tie_truth_stats, true_ties
    K = np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]])
    cal = StereoCal(K, make_T(np.eye(3), [0.27, 0, 0]), 640, 480)
    R_b_c = np.array([[0, 0, 1.0], [-1, 0, 0], [0, -1, 0]])
    T_b_c = make_T(R_b_c, [0, 0, 1.5])
    img = np.zeros((480, 640), np.uint8)
    sites = [Site(k, k, (StereoPair(img, img, T_b_c),), cal, np.eye(4), np.eye(6)) for k in range(2)]
    T0, T1 = np.eye(4), make_T(rot_z(0.1), [8.0, 0.5, 0.0])
    rng = np.random.default_rng(1)
    P_w = np.column_stack([rng.uniform(12, 30, 40), rng.uniform(-4, 4, 40), rng.uniform(-0.3, 0.3, 40)])
    uv0, _ = project(T0 @ T_b_c, K, P_w)
    uv1, z1 = project(T1 @ T_b_c, K, P_w)
    n = len(P_w)
    ties = TieSet(np.zeros(n, int), uv0, np.zeros(n, int), uv1)
    ties.ur_cur = uv1[:, 0] - 600.0 * 0.27 / z1
    ties.ur_prev = np.full(n, np.nan)
    ties.stereo_ok = np.ones(n, bool)
    ties.inlier = np.ones(n, bool)
    assert true_ties(sites[0], sites[1], ties, T0, T1).all()
    ties.uv_prev = uv0 + np.where(np.arange(n)[:, None] % 2 == 0, 10.0, 0.0)
    t = true_ties(sites[0], sites[1], ties, T0, T1)
    assert np.array_equal(t, np.arange(n) % 2 == 1)
    st = tie_truth_stats(sites[0], sites[1], ties, T0, T1)
    assert st["n_true_inliers"] == n // 2 and st["true_inliers_beyond_20m"] <= n // 2
