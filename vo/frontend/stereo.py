"""Calibrated stereo geometry for the front-ends: undistortion, fundamental matrix, epipolar check,
triangulation with cheirality / range / reprojection checks.

Frames: ``c0`` left, ``c1`` right camera (OpenCV); ``T_c0_c1`` from the rig (``p_c0 = T_c0_c1 @ p_c1``).
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import inv_T, skew, transform_points
from rigs.geometry.pinhole import project as project_pinhole, to_normalized, to_pixels, undistort_points
from rigs.geometry.triangulation import triangulate_normalized

# OpenCV's default fixed-point iterations (cv2.undistortPoints without criteria): within 7.3e-6 px of the
# exact inverse over cart27's images (pinhole.undistort_exact), far below the front-ends' 1 px gates.
UNDISTORT_ITERS = 5


def undistort_px(pts: np.ndarray, camera) -> np.ndarray:
    """(N,2) raw pixels -> (N,2) pixels of the ideal (undistorted) pinhole with the same K."""
    p = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
    if p.shape[0] == 0 or not camera.has_distortion:
        return p.copy()
    return to_pixels(undistort_points(p, camera.K, camera.dist_coeffs, iters=UNDISTORT_ITERS, eps=None), camera.K)


def normalized(pts_undist_px: np.ndarray, camera) -> np.ndarray:
    """(N,2) undistorted pixels -> (N,2) normalised image coordinates ``(x/z, y/z)``."""
    return to_normalized(pts_undist_px, camera.K)


def fundamental_from_rig(rig) -> np.ndarray:
    """(3,3) F with ``x1^T F x0 = 0`` for undistorted pixels ``x0`` (left) and ``x1`` (right).

    ``E = [t_c1_c0]_x R_c1_c0`` (from ``p_c1 = R_c1_c0 p_c0 + t_c1_c0``), ``F = K1^-T E K0^-1``.
    """
    T_c1_c0 = inv_T(rig.T_c0_c1)
    E = skew(T_c1_c0[:3, 3]) @ T_c1_c0[:3, :3]
    K0, K1 = rig.cameras[0].K, rig.cameras[1].K
    return np.linalg.inv(K1).T @ E @ np.linalg.inv(K0)


def signed_epipolar_distances(F: np.ndarray, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
    """(N,) signed symmetric epipolar distance (px) of undistorted pixel pairs ``x0`` (left), ``x1``
    (right): ``x1^T F x0`` over the smaller of the two lines' normal lengths, so that its magnitude is
    the larger of the two point-to-line distances (:func:`epipolar_distances`)."""
    if len(x0) == 0:
        return np.zeros(0)
    h0 = np.column_stack([x0, np.ones(len(x0))])
    h1 = np.column_stack([x1, np.ones(len(x1))])
    l1, l0 = h0 @ F.T, h1 @ F
    num = np.sum(h1 * l1, axis=1)
    norm = np.minimum(np.hypot(l1[:, 0], l1[:, 1]), np.hypot(l0[:, 0], l0[:, 1]))
    return num / np.maximum(norm, 1e-12)


def epipolar_distances(F: np.ndarray, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
    """(N,) symmetric epipolar distance in px: max of (x1 to line F x0) and (x0 to line F^T x1)."""
    return np.abs(signed_epipolar_distances(F, x0, x1))


def epipolar_mask(rig, p_left_px: np.ndarray, p_right_px: np.ndarray, threshold_px: float = 1.0) -> np.ndarray:
    """(N,) bool: raw left/right pixel pairs whose undistorted points lie within ``threshold_px``
    of each other's epipolar line (calibrated geometry of ``rig``)."""
    x0 = undistort_px(p_left_px, rig.cameras[0])
    x1 = undistort_px(p_right_px, rig.cameras[1])
    return epipolar_distances(fundamental_from_rig(rig), x0, x1) < threshold_px


def triangulate(rig, p_left_px: np.ndarray, p_right_px: np.ndarray, max_depth: float = 80.0,
                max_reproj_px: float = 1.0) -> tuple:
    """Triangulate raw left/right pixel pairs -> ``(p_c0 (N,3), ok (N,) bool)``.

    Linear triangulation of the normalised coordinates (:func:`rigs.geometry.triangulation.triangulate_normalized`).
    ``ok`` requires positive depth in both cameras, left depth <= ``max_depth`` (m) and reprojection error
    <= ``max_reproj_px`` in both (undistorted) images.
    """
    n = len(p_left_px)
    if n == 0:
        return np.zeros((0, 3)), np.zeros(0, bool)
    c0, c1 = rig.cameras[0], rig.cameras[1]
    x0, x1 = undistort_px(p_left_px, c0), undistort_px(p_right_px, c1)
    T_c1_c0 = inv_T(rig.T_c0_c1)
    p_c0 = triangulate_normalized(normalized(x0, c0), normalized(x1, c1), np.eye(4), T_c1_c0)
    p_c1 = transform_points(T_c1_c0, p_c0)
    ok = np.all(np.isfinite(p_c0), axis=1) & (p_c0[:, 2] > 1e-6) & (p_c1[:, 2] > 1e-6) & (p_c0[:, 2] <= max_depth)
    safe0, safe1 = np.where(ok[:, None], p_c0, 1.0), np.where(ok[:, None], p_c1, 1.0)
    e0 = np.linalg.norm(project(safe0, c0) - x0, axis=1)
    e1 = np.linalg.norm(project(safe1, c1) - x1, axis=1)
    ok &= (e0 <= max_reproj_px) & (e1 <= max_reproj_px)
    return np.where(ok[:, None], p_c0, 0.0), ok


def project(p_c: np.ndarray, camera) -> np.ndarray:
    """(N,3) points in the camera frame -> (N,2) undistorted pixels (pinhole K only)."""
    return project_pinhole(p_c, camera.K)
