"""Two-view triangulation for calibrated pinhole cameras, on plain arrays.

Poses ``T_c_x`` (4,4) map points of a frame ``x`` into a camera (``p_c = T_c_x p_x``); on normalised
coordinates the camera's projection matrix is ``T_c_x[:3]``. For a stereo pair in its left camera's
frame, ``T_c0_c0 = I`` and ``T_c1_c0`` (``p_c1 = R_c1_c0 p_c0 + t_c1_c0``). Pixels here are undistorted
(ideal pinhole); undistort first with :mod:`rigs.geometry.pinhole`.
"""
from __future__ import annotations

import cv2
import numpy as np

from rigs.geometry.pinhole import project, project_jacobian
from rigs.geometry.se3 import transform_points


def triangulate_normalized(xy_a: np.ndarray, xy_b: np.ndarray, T_ca_x: np.ndarray, T_cb_x: np.ndarray
                           ) -> np.ndarray:
    """Linear (DLT) triangulation of normalised matches ``xy_a``, ``xy_b`` (N,2) seen by cameras ``a``
    and ``b`` at poses ``T_ca_x``, ``T_cb_x`` (4,4; ``p_ca = T_ca_x p_x``) -> points ``p_x`` (N,3) in frame x.

    ``cv2.triangulatePoints`` with ``P_a = T_ca_x[:3]``, ``P_b = T_cb_x[:3]`` (a stereo pair in its left
    camera's frame: ``T_ca_x = I``, ``T_cb_x = T_c1_c0``); rows whose homogeneous ``w`` is below 1e-12 in
    magnitude (points at infinity) are NaN. No cheirality check."""
    xy_a = np.asarray(xy_a, dtype=np.float64).reshape(-1, 2)
    xy_b = np.asarray(xy_b, dtype=np.float64).reshape(-1, 2)
    if len(xy_a) == 0:
        return np.zeros((0, 3))
    P_a, P_b = (np.asarray(T, dtype=np.float64)[:3, :] for T in (T_ca_x, T_cb_x))
    X = cv2.triangulatePoints(P_a, P_b, xy_a.T, xy_b.T)
    w = X[3]
    with np.errstate(divide="ignore", invalid="ignore"):
        return (X[:3] / np.where(np.abs(w) > 1e-12, w, np.nan)).T


def two_view_jacobian(K0: np.ndarray, K1: np.ndarray, T_c1_c0: np.ndarray, p_c0: np.ndarray) -> np.ndarray:
    """(4,3) ``d [uv0, uv1] / d p_c0`` of the ideal pinhole projections of one point ``p_c0`` (3,)."""
    p_c0 = np.asarray(p_c0, dtype=np.float64).reshape(1, 3)
    J0 = project_jacobian(p_c0, K0)[0]
    J1 = project_jacobian(transform_points(T_c1_c0, p_c0), K1)[0] @ np.asarray(T_c1_c0)[:3, :3]
    return np.vstack([J0, J1])


def triangulate_ml(uv0: np.ndarray, uv1: np.ndarray, K0: np.ndarray, K1: np.ndarray, T_c1_c0: np.ndarray,
                   iters: int = 10) -> np.ndarray:
    """Maximum-likelihood point ``p_c0`` (3,) of one undistorted pixel match ``uv0``, ``uv1`` (2,) under
    isotropic pixel noise: Gauss-Newton on the reprojection error in both images from the linear
    solution, until the step is below 1e-12 m or after ``iters`` steps."""
    uv0 = np.asarray(uv0, dtype=np.float64).reshape(2)
    uv1 = np.asarray(uv1, dtype=np.float64).reshape(2)
    K0, K1, T_c1_c0 = (np.asarray(a, dtype=np.float64) for a in (K0, K1, T_c1_c0))
    xy0 = np.linalg.solve(K0, np.r_[uv0, 1.0])[:2]
    xy1 = np.linalg.solve(K1, np.r_[uv1, 1.0])[:2]
    p = triangulate_normalized(xy0, xy1, np.eye(4), T_c1_c0)[0]
    for _ in range(iters):
        r = np.concatenate([project(p, K0)[0] - uv0, project(transform_points(T_c1_c0, p[None]), K1)[0] - uv1])
        step = np.linalg.lstsq(two_view_jacobian(K0, K1, T_c1_c0, p), -r, rcond=None)[0]
        p = p + step
        if np.linalg.norm(step) < 1e-12:
            break
    return p
