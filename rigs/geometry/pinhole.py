"""Pinhole camera with OpenCV's radial-tangential lens distortion, on plain arrays.

Camera frame OpenCV (x right, y down, z forward). ``K`` (3,3) ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``;
``dist`` (5,) ``(k1, k2, p1, p2, k3)`` or ``None`` (no lens distortion). Normalised image coordinates
``xy = (x/z, y/z)`` (N,2); pixels ``uv`` (N,2); points ``p_c`` (N,3).

OpenCV's model maps undistorted normalised ``xy`` to distorted ``xy_d = D(xy)``::

    r2 = x^2 + y^2,  rad = 1 + k1 r2 + k2 r2^2 + k3 r2^3
    x_d = x rad + 2 p1 x y + p2 (r2 + 2 x^2),  y_d = y rad + p1 (r2 + 2 y^2) + 2 p2 x y

and ``uv = K [xy_d, 1]``. ``D`` has no closed-form inverse: :func:`undistort_points` is OpenCV's
fixed-point iteration (``cv2.undistortPoints``); :func:`undistort_exact` polishes it with Newton's
method on the analytic Jacobian of :func:`distort_with_jacobian` down to steps below 1e-14.
"""
from __future__ import annotations

import cv2
import numpy as np

ZERO_DIST = (0.0, 0.0, 0.0, 0.0, 0.0)


def intrinsic_matrix(fx: float, fy: float, cx: float, cy: float) -> np.ndarray:
    """Focal lengths and principal point (px) -> (3,3) ``K``."""
    return np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


def to_normalized(uv: np.ndarray, K: np.ndarray) -> np.ndarray:
    """(N,2) pixels -> (N,2) ``((u - cx) / fx, (v - cy) / fy)`` (removes ``K`` only, not distortion)."""
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    return np.column_stack([(uv[:, 0] - K[0, 2]) / K[0, 0], (uv[:, 1] - K[1, 2]) / K[1, 1]])


def to_pixels(xy: np.ndarray, K: np.ndarray) -> np.ndarray:
    """(N,2) normalised coordinates -> (N,2) pixels ``(fx x + cx, fy y + cy)`` (applies ``K`` only)."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    return np.column_stack([K[0, 0] * xy[:, 0] + K[0, 2], K[1, 1] * xy[:, 1] + K[1, 2]])


def distort_with_jacobian(xy: np.ndarray, dist) -> tuple[np.ndarray, np.ndarray]:
    """(N,2) undistorted normalised ``xy`` -> ``(xy_d (N,2), J (N,2,2) = d xy_d / d xy)``."""
    k1, k2, p1, p2, k3 = ZERO_DIST if dist is None else np.asarray(dist, dtype=np.float64).reshape(5)
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    x, y = xy[:, 0], xy[:, 1]
    r2 = x * x + y * y
    rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    drad = k1 + r2 * (2 * k2 + 3 * k3 * r2)          # d rad / d r2
    xd = x * rad + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * rad + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    J = np.empty((len(x), 2, 2))
    J[:, 0, 0] = rad + 2 * x * x * drad + 2 * p1 * y + 6 * p2 * x
    J[:, 0, 1] = 2 * x * y * drad + 2 * p1 * x + 2 * p2 * y
    J[:, 1, 0] = J[:, 0, 1]
    J[:, 1, 1] = rad + 2 * y * y * drad + 6 * p1 * y + 2 * p2 * x
    return np.stack([xd, yd], axis=1), J


def distort(xy: np.ndarray, dist) -> np.ndarray:
    """(N,2) undistorted normalised ``xy`` -> (N,2) distorted normalised ``xy_d``."""
    return distort_with_jacobian(xy, dist)[0]


def undistort_points(uv_d: np.ndarray, K: np.ndarray, dist, iters: int = 30, eps: float | None = 1e-12
                     ) -> np.ndarray:
    """(N,2) distorted pixels -> (N,2) undistorted normalised ``xy`` by OpenCV's fixed-point iteration.

    ``cv2.undistortPoints`` with at most ``iters`` iterations, stopping early once its reprojection
    error is below ``eps`` (``eps=None``: exactly ``iters`` iterations, OpenCV's default criteria are
    ``iters=5, eps=None``). Converges for mild lenses; see :func:`undistort_exact` for the exact inverse."""
    uv = np.ascontiguousarray(np.asarray(uv_d, dtype=np.float64).reshape(-1, 1, 2))
    if len(uv) == 0:
        return np.zeros((0, 2))
    d = np.zeros(5) if dist is None else np.asarray(dist, dtype=np.float64)
    kind = cv2.TERM_CRITERIA_COUNT if eps is None else cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS
    crit = (kind, int(iters), 0.0 if eps is None else float(eps))
    return cv2.undistortPoints(uv, np.asarray(K, dtype=np.float64), d, criteria=crit).reshape(-1, 2)


def undistort_exact(uv_d: np.ndarray, K: np.ndarray, dist, iters: int = 30) -> np.ndarray:
    """(N,2) distorted pixels -> (N,2) undistorted normalised ``xy`` with ``distort(xy) = K^-1 uv_d``
    to machine precision: :func:`undistort_points` (50 iterations) refined by up to ``iters`` Newton
    steps, stopping once every step is below 1e-14. OpenCV 5 has no ``undistortPointsIter``."""
    uv_d = np.asarray(uv_d, dtype=np.float64).reshape(-1, 2)
    xy = undistort_points(uv_d, K, dist, iters=50, eps=1e-12)
    if dist is None or len(uv_d) == 0:
        return xy
    target = to_normalized(uv_d, K)
    for _ in range(iters):
        xd, J = distort_with_jacobian(xy, dist)
        step = np.linalg.solve(J, (xd - target)[:, :, None])[:, :, 0]
        xy = xy - step
        if np.max(np.abs(step)) < 1e-14:
            break
    return xy


def project(p_c: np.ndarray, K: np.ndarray, dist=None) -> np.ndarray:
    """(N,3) camera-frame points -> (N,2) pixels.

    ``dist=None``: ideal pinhole ``(fx x/z + cx, fy y/z + cy)`` in numpy (undistorted pixels);
    otherwise ``cv2.projectPoints`` with ``dist`` (distorted pixels). Points need ``z != 0``."""
    p_c = np.asarray(p_c, dtype=np.float64).reshape(-1, 3)
    if dist is None:
        z = p_c[:, 2]
        return np.column_stack([K[0, 0] * p_c[:, 0] / z + K[0, 2], K[1, 1] * p_c[:, 1] / z + K[1, 2]])
    if len(p_c) == 0:
        return np.zeros((0, 2))
    uv, _ = cv2.projectPoints(p_c, np.zeros(3), np.zeros(3), np.asarray(K, dtype=np.float64),
                              np.asarray(dist, dtype=np.float64))
    return uv.reshape(-1, 2)


def project_jacobian(p_c: np.ndarray, K: np.ndarray) -> np.ndarray:
    """(N,3) camera-frame points -> (N,2,3) ``d uv / d p_c`` of the ideal pinhole projection."""
    p_c = np.asarray(p_c, dtype=np.float64).reshape(-1, 3)
    x, y, z = p_c[:, 0], p_c[:, 1], p_c[:, 2]
    J = np.zeros((len(p_c), 2, 3))
    J[:, 0, 0] = K[0, 0] / z
    J[:, 0, 2] = -K[0, 0] * x / z ** 2
    J[:, 1, 1] = K[1, 1] / z
    J[:, 1, 2] = -K[1, 1] * y / z ** 2
    return J


def backproject(uv_d: np.ndarray, K: np.ndarray, dist=None, z=None) -> np.ndarray:
    """(N,2) (distorted) pixels -> (N,3) camera-frame points ``[x, y, 1] * z`` on their rays, undistorted
    with :func:`undistort_points`; ``z`` (N,) optical-axis depths, ``None``: unit depth (the rays)."""
    xy = undistort_points(uv_d, K, dist)
    rays = np.column_stack([xy, np.ones(len(xy))])
    return rays if z is None else rays * np.asarray(z, dtype=np.float64).reshape(-1, 1)
