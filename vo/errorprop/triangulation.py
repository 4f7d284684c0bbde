"""First-order covariance of a triangulated point, for any calibrated two-camera rig.

The maximum-likelihood point ``X`` minimises the pixel reprojection error in both cameras;
to first order its covariance is ``(J^T Sigma_u^-1 J)^-1`` with ``J`` (4,3) the Jacobian of the
two pinhole projections at ``X`` and ``Sigma_u`` the pixel noise (isotropic ``sigma_p``). This
holds for non-parallel cameras (e.g. ``cart27``) where the normal-case formula of seed 001
eq. 7 does not apply; for a parallel rig it reduces to ``sigma_Z = Z^2 sigma_d / (b f)`` with
the disparity error ``sigma_d = sqrt(2) sigma_p``.
"""
from __future__ import annotations

import numpy as np


def _project(K: np.ndarray, T_c_x: np.ndarray, p_x: np.ndarray) -> np.ndarray:
    p_c = T_c_x[:3, :3] @ p_x + T_c_x[:3, 3]
    return (K[:2, :2] @ (p_c[:2] / p_c[2])) + K[:2, 2]


def _project_jacobian(K: np.ndarray, T_c_x: np.ndarray, p_x: np.ndarray) -> np.ndarray:
    """(2,3) d(pixel)/d(p_x)."""
    p_c = T_c_x[:3, :3] @ p_x + T_c_x[:3, 3]
    x, y, z = p_c
    d_norm = np.array([[1 / z, 0, -x / z ** 2], [0, 1 / z, -y / z ** 2]])
    return K[:2, :2] @ d_norm @ T_c_x[:3, :3]


def triangulate(K0, K1, T_c0_c1, u0, u1, iters: int = 10) -> np.ndarray:
    """ML triangulation (Gauss-Newton from the linear DLT solution) of pixels ``u0``, ``u1`` -> ``p_c0`` (3,)."""
    T_c1_c0 = np.linalg.inv(T_c0_c1)
    P0 = K0 @ np.eye(4)[:3]
    P1 = K1 @ T_c1_c0[:3]
    A = np.stack([u0[0] * P0[2] - P0[0], u0[1] * P0[2] - P0[1], u1[0] * P1[2] - P1[0], u1[1] * P1[2] - P1[1]])
    X = np.linalg.svd(A)[2][-1]
    p = X[:3] / X[3]
    for _ in range(iters):
        r = np.concatenate([_project(K0, np.eye(4), p) - u0, _project(K1, T_c1_c0, p) - u1])
        J = np.vstack([_project_jacobian(K0, np.eye(4), p), _project_jacobian(K1, T_c1_c0, p)])
        step = np.linalg.lstsq(J, -r, rcond=None)[0]
        p = p + step
        if np.linalg.norm(step) < 1e-12:
            break
    return p


def triangulation_covariance(K0, K1, T_c0_c1, p_c0, sigma_p_px: float) -> np.ndarray:
    """(3,3) first-order covariance of the triangulated point ``p_c0`` (left-camera frame, m^2)."""
    T_c1_c0 = np.linalg.inv(T_c0_c1)
    p = np.asarray(p_c0, dtype=float)
    J = np.vstack([_project_jacobian(np.asarray(K0), np.eye(4), p), _project_jacobian(np.asarray(K1), T_c1_c0, p)])
    return np.linalg.inv(J.T @ J) * sigma_p_px ** 2
