"""rigs.geometry.triangulation: exact points of a non-parallel rig are recovered from their projections."""
import numpy as np

from rigs.geometry import inv_T, make_T, rot_y, transform_points
from rigs.geometry.pinhole import intrinsic_matrix, project, to_normalized
from rigs.geometry.triangulation import triangulate_ml, triangulate_normalized, two_view_jacobian

K0 = intrinsic_matrix(460.0, 455.0, 367.0, 248.0)
K1 = intrinsic_matrix(458.0, 457.0, 371.0, 251.0)
T_c0_c1 = make_T(rot_y(np.radians(4.0)), [0.27, 0.004, -0.01])     # toed-in, like cart27
T_c1_c0 = inv_T(T_c0_c1)


def _points(n=300, seed=3):
    rng = np.random.default_rng(seed)
    return np.c_[rng.uniform(-3, 3, n), rng.uniform(-2, 2, n), rng.uniform(1.0, 40, n)]


def test_linear_triangulation_recovers_exact_points():
    p_c0 = _points()
    xy0 = p_c0[:, :2] / p_c0[:, 2:]
    p_c1 = transform_points(T_c1_c0, p_c0)
    xy1 = p_c1[:, :2] / p_c1[:, 2:]
    np.testing.assert_allclose(triangulate_normalized(xy0, xy1, np.eye(4), T_c1_c0), p_c0, rtol=1e-9)


def test_two_camera_poses_give_points_in_their_common_frame():
    p_w = _points() + [5.0, -2.0, 3.0]
    T_ca_w = make_T(rot_y(0.3), [-1.0, 0.5, 2.0])
    T_cb_w = T_c1_c0 @ make_T(rot_y(-0.1), [0.4, 0.0, -0.5]) @ T_ca_w
    xy = [(lambda q: q[:, :2] / q[:, 2:])(transform_points(T, p_w)) for T in (T_ca_w, T_cb_w)]
    np.testing.assert_allclose(triangulate_normalized(xy[0], xy[1], T_ca_w, T_cb_w), p_w, rtol=1e-8)


def test_point_at_infinity_is_nan():
    xy = np.array([[0.1, -0.05]])
    T_parallel = make_T(np.eye(3), [-0.27, 0.0, 0.0])              # same direction in a parallel rig: zero disparity
    assert np.all(np.isnan(triangulate_normalized(xy, xy, np.eye(4), T_parallel)))


def test_ml_triangulation_recovers_exact_point_and_fits_noisy_pixels():
    p = np.array([0.8, -0.3, 12.0])
    u0 = project(p[None], K0)[0]
    u1 = project(transform_points(T_c1_c0, p[None]), K1)[0]
    np.testing.assert_allclose(triangulate_ml(u0, u1, K0, K1, T_c1_c0), p, rtol=1e-10)
    # with pixel noise the ML point has zero reprojection gradient: J^T r = 0 (normal equations)
    rng = np.random.default_rng(0)
    v0, v1 = u0 + rng.normal(0, 0.5, 2), u1 + rng.normal(0, 0.5, 2)
    q = triangulate_ml(v0, v1, K0, K1, T_c1_c0)
    r = np.r_[project(q[None], K0)[0] - v0, project(transform_points(T_c1_c0, q[None]), K1)[0] - v1]
    J = two_view_jacobian(K0, K1, T_c1_c0, q)
    assert np.abs(J.T @ r).max() < 1e-9 * np.abs(J).max()
    # and reduces the reprojection error of the linear solution on the same pixels
    lin = triangulate_normalized(to_normalized(v0[None], K0), to_normalized(v1[None], K1), np.eye(4), T_c1_c0)[0]
    r_lin = np.r_[project(lin[None], K0)[0] - v0, project(transform_points(T_c1_c0, lin[None]), K1)[0] - v1]
    assert r @ r <= r_lin @ r_lin + 1e-12
