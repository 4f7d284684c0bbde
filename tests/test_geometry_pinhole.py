"""rigs.geometry.pinhole: projection with OpenCV radtan distortion and its inverses, checked against
OpenCV's own projection and by round trips on exact synthetic points."""
import cv2
import numpy as np
import pytest

from rigs.geometry import pinhole

K = pinhole.intrinsic_matrix(460.0, 455.0, 367.0, 248.0)
DIST = np.array([0.0176, -0.0356, -0.0006, -0.0005, 0.0507])     # cart27's left lens
STRONG = np.array([-0.28, 0.07, 0.0002, 0.00002, 0.0])             # EuRoC-like barrel lens


def _points(n=400, seed=0):
    """(n,3) points seen inside a 720x480 image (|x/z| < 0.78, |y/z| < 0.53), 1.5 to 30 m deep."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(1.5, 30, n)
    return np.c_[rng.uniform([-0.78, -0.53], [0.78, 0.53], (n, 2)) * z[:, None], z]


@pytest.mark.parametrize("dist", [DIST, STRONG])
def test_distort_matches_opencv_projection(dist):
    p_c = _points()
    uv_cv, _ = cv2.projectPoints(p_c, np.zeros(3), np.zeros(3), K, dist)
    uv = pinhole.to_pixels(pinhole.distort(p_c[:, :2] / p_c[:, 2:], dist), K)
    np.testing.assert_allclose(uv, uv_cv.reshape(-1, 2), atol=1e-9)           # same polynomial, float rounding
    np.testing.assert_array_equal(pinhole.project(p_c, K, dist), uv_cv.reshape(-1, 2))


def _central_difference(f, x: np.ndarray, h: float) -> np.ndarray:
    """(N,m) -> (N,2,m) numerical Jacobian of the row-wise map ``f`` (error ~h^2)."""
    cols = []
    for k in range(x.shape[1]):
        e = np.zeros(x.shape[1])
        e[k] = h
        cols.append((f(x + e) - f(x - e)) / (2 * h))
    return np.stack(cols, axis=2)


def test_distortion_jacobian_matches_finite_differences():
    xy = _points()[:, :2] / 10.0
    _, J = pinhole.distort_with_jacobian(xy, STRONG)
    np.testing.assert_allclose(J, _central_difference(lambda a: pinhole.distort(a, STRONG), xy, 1e-7), atol=1e-7)


@pytest.mark.parametrize("dist", [DIST, STRONG])
def test_undistort_exact_inverts_distortion(dist):
    p_c = _points()
    xy_true = p_c[:, :2] / p_c[:, 2:]
    uv_d = pinhole.project(p_c, K, dist)
    xy = pinhole.undistort_exact(uv_d, K, dist)
    np.testing.assert_allclose(xy, xy_true, atol=1e-13)                        # machine precision
    np.testing.assert_allclose(pinhole.project(np.c_[xy, np.ones(len(xy))], K, dist), uv_d, atol=1e-9)


def test_opencv_iteration_is_looser_than_exact_on_a_strong_lens():
    p_c = _points()
    xy_true = p_c[:, :2] / p_c[:, 2:]
    uv_d = pinhole.project(p_c, K, STRONG)
    err5 = np.abs(pinhole.undistort_points(uv_d, K, STRONG, iters=5, eps=None) - xy_true).max()
    err_exact = np.abs(pinhole.undistort_exact(uv_d, K, STRONG) - xy_true).max()
    assert err_exact < 1e-13 < err5                  # five fixed-point steps leave a visible residual


def test_project_backproject_round_trip():
    p_c = _points()
    uv = pinhole.project(p_c, K, DIST)
    np.testing.assert_allclose(pinhole.backproject(uv, K, DIST, p_c[:, 2]), p_c, rtol=1e-11)
    rays = pinhole.backproject(uv, K, DIST)
    np.testing.assert_array_equal(rays[:, 2], 1.0)
    uv_pin = pinhole.project(p_c, K)                                            # no distortion: numpy pinhole
    np.testing.assert_allclose(pinhole.backproject(uv_pin, K, None, p_c[:, 2]), p_c, rtol=1e-13)
    np.testing.assert_allclose(pinhole.to_normalized(pinhole.to_pixels(rays[:, :2], K), K), rays[:, :2], atol=1e-15)


def test_project_jacobian_matches_finite_differences():
    p_c = _points(50)
    J = pinhole.project_jacobian(p_c, K)
    np.testing.assert_allclose(J, _central_difference(lambda a: pinhole.project(a, K), p_c, 1e-6), atol=1e-6)


def test_empty_inputs():
    assert pinhole.undistort_points(np.zeros((0, 2)), K, DIST).shape == (0, 2)
    assert pinhole.undistort_exact(np.zeros((0, 2)), K, DIST).shape == (0, 2)
    assert pinhole.project(np.zeros((0, 3)), K, DIST).shape == (0, 2)
