"""Exact image points from rendered depth and true poses (validation only: a real estimator never
sees depth or truth). Used by :mod:`sim.app.validation.truth_tracks`, :mod:`sim.app.validation.render_fidelity`
and the diagnostic scripts of docs/consistency.md.

Shapes: pixels ``p`` (N,2) (u, v), depths ``z`` (N,), points ``X`` (N,3), poses (4,4).
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import pinhole

PLANE_TOL = 0.005                   # max inverse-depth plane residual / inverse depth in the 5x5 window


def local_depth(depth: np.ndarray, p: np.ndarray, tol: float = PLANE_TOL) -> tuple[np.ndarray, np.ndarray]:
    """(z (N,), ok (N,)) at subpixel ``p`` (N,2) in ``depth`` (H,W) metres.

    Inverse depth is affine in the pixel coordinates on a plane, so a plane fitted to the 5x5 window's
    inverse depth interpolates ground at grazing angles exactly; ``ok`` where its max residual is below
    ``tol`` x the inverse depth (no depth discontinuity) and the depth is finite and > 0.1 m."""
    p = np.asarray(p, float).reshape(-1, 2)
    h, w = depth.shape
    ij = np.clip(np.round(p).astype(int), 2, [w - 3, h - 3])
    d = np.array([(di, dj) for dj in range(-2, 3) for di in range(-2, 3)])
    win = np.stack([depth[ij[:, 1] + dj, ij[:, 0] + di] for di, dj in d], 1).astype(float)   # (N, 25)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(np.isfinite(win) & (win > 0.1), 1.0 / win, np.nan)
    A = np.c_[d, np.ones(len(d))]
    coef = np.linalg.lstsq(A, np.nan_to_num(inv).T, rcond=None)[0]                            # (3, N)
    resid = np.abs(A @ coef - inv.T).max(axis=0)
    off = p - ij
    inv_p = coef[0] * off[:, 0] + coef[1] * off[:, 1] + coef[2]
    with np.errstate(invalid="ignore"):
        ok = np.all(np.isfinite(inv), axis=1) & (resid < tol * np.abs(coef[2])) & (inv_p > 0)
    return 1.0 / np.where(ok, inv_p, 1.0), ok


def project(camera, T_w_c: np.ndarray, X_w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(uv (N,2), in_front (N,)) of world points ``X_w`` (N,3) in ``camera`` at pose ``T_w_c`` (4,4)."""
    X_c = (np.asarray(X_w, float).reshape(-1, 3) - T_w_c[:3, 3]) @ T_w_c[:3, :3]
    if not len(X_c):
        return np.zeros((0, 2)), np.zeros(0, bool)
    if camera.is_fisheye:                  # cv2.fisheye.projectPoints
        return camera.project(X_c), X_c[:, 2] > 0.1
    return pinhole.project(X_c, camera.K, camera.dist_coeffs), X_c[:, 2] > 0.1


def backproject(camera, p: np.ndarray, z: np.ndarray) -> np.ndarray:
    """(N,3) camera-frame points at pixels ``p`` (N,2, distorted) with optical-axis depths ``z`` (N,)."""
    if camera.is_fisheye:                  # cv2.fisheye.undistortPoints
        xy = camera.undistort_normalized(np.asarray(p, float).reshape(-1, 2))
        return np.column_stack([xy, np.ones(len(xy))]) * np.asarray(z, dtype=np.float64).reshape(-1, 1)
    return pinhole.backproject(p, camera.K, camera.dist_coeffs, z)


def exact_positions(camera_a, camera_b, p_a: np.ndarray, depth_a: np.ndarray, T_a_b: np.ndarray) -> tuple:
    """(p_b (N,2), ok (N,)): where the surface points seen at pixels ``p_a`` of camera a (depth image
    ``depth_a`` (H,W), :func:`local_depth`) appear in camera b at pose ``T_a_b`` (b in a's frame)."""
    z, ok = local_depth(depth_a, p_a)
    p_b, front = project(camera_b, T_a_b, backproject(camera_a, p_a, z))
    return p_b, ok & front
