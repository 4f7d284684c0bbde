"""Initial values for the bundle adjustment (seed 001 §2.3): space intersection at the previous site,
resection at the current site, and eq. 3 for the right image.
"""
from __future__ import annotations

from typing import Optional

import cv2
import numpy as np

from rigs.geometry import inv_T, make_T


def intersect_rectified(uv_l: np.ndarray, u_r: np.ndarray, K: np.ndarray, baseline: float) -> np.ndarray:
    """Space intersection of a rectified pair: (N,3) points in the left camera frame,
    ``Z = f B / d``, ``X = (u - cx) Z / fx``, ``Y = (v - cy) Z / fy`` with ``d = u_l - u_r``."""
    uv_l = np.asarray(uv_l, float).reshape(-1, 2)
    d = uv_l[:, 0] - np.asarray(u_r, float)
    Z = K[0, 0] * baseline / d
    return np.column_stack([(uv_l[:, 0] - K[0, 2]) * Z / K[0, 0], (uv_l[:, 1] - K[1, 2]) * Z / K[1, 1], Z])


def right_from_left(T_w_c0: np.ndarray, T_c0_c1: np.ndarray) -> np.ndarray:
    """Eq. 3: ``R_right = R_left R_r``, ``T_right = R_left T_r + T_left``, i.e. ``T_w_c1 = T_w_c0 T_c0_c1``."""
    R = T_w_c0[:3, :3] @ T_c0_c1[:3, :3]
    t = T_w_c0[:3, :3] @ T_c0_c1[:3, 3] + T_w_c0[:3, 3]
    return make_T(R, t)


def resection(P_w: np.ndarray, uv: np.ndarray, K: np.ndarray, T_w_c_guess: np.ndarray,
              reproj_px: float, seed: int = 0) -> Optional[tuple]:
    """Resection of one image: ``cv2.solvePnPRansac`` (started from ``T_w_c_guess``) then
    ``cv2.solvePnPRefineLM`` on the inliers. -> (T_w_c (4,4), inlier indices) or None."""
    P_w = np.ascontiguousarray(P_w, dtype=np.float64).reshape(-1, 3)
    uv = np.ascontiguousarray(uv, dtype=np.float64).reshape(-1, 2)
    if len(P_w) < 4:
        return None
    T_c_w = inv_T(T_w_c_guess)
    rvec, _ = cv2.Rodrigues(T_c_w[:3, :3])
    tvec = T_c_w[:3, 3].reshape(3, 1).copy()
    cv2.setRNGSeed(int(seed))
    ok, rvec, tvec, inl = cv2.solvePnPRansac(P_w, uv, K, None, rvec, tvec, useExtrinsicGuess=True,
                                             iterationsCount=200, reprojectionError=float(reproj_px),
                                             confidence=0.999, flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok or inl is None or len(inl) < 4:
        return None
    inl = inl.ravel()
    rvec, tvec = cv2.solvePnPRefineLM(P_w[inl], uv[inl], K, None, rvec, tvec)
    R, _ = cv2.Rodrigues(rvec)
    return inv_T(make_T(R, tvec.ravel())), inl
