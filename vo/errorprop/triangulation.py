"""First-order covariance of a triangulated point, for any calibrated two-camera rig.

The maximum-likelihood point ``X`` minimises the pixel reprojection error in both cameras
(:func:`rigs.geometry.triangulation.triangulate_ml`); to first order its covariance is
``(J^T Sigma_u^-1 J)^-1`` with ``J`` (4,3) the Jacobian of the two pinhole projections at ``X``
and ``Sigma_u`` the pixel noise (isotropic ``sigma_p``). This holds for non-parallel cameras
(e.g. ``cart27``) where the normal-case formula of seed 001 eq. 7 does not apply; for a parallel
rig it reduces to ``sigma_Z = Z^2 sigma_d / (b f)`` with the disparity error ``sigma_d = sqrt(2) sigma_p``.
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import inv_T
from rigs.geometry.triangulation import triangulate_ml, two_view_jacobian


def triangulate(K0, K1, T_c0_c1, u0, u1, iters: int = 10) -> np.ndarray:
    """ML triangulation of one undistorted pixel match ``u0``, ``u1`` (2,) -> ``p_c0`` (3,)."""
    return triangulate_ml(u0, u1, K0, K1, inv_T(np.asarray(T_c0_c1, dtype=float)), iters=iters)


def triangulation_covariance(K0, K1, T_c0_c1, p_c0, sigma_p_px: float) -> np.ndarray:
    """(3,3) first-order covariance of the triangulated point ``p_c0`` (left-camera frame, m^2)."""
    J = two_view_jacobian(np.asarray(K0, dtype=float), np.asarray(K1, dtype=float),
                          inv_T(np.asarray(T_c0_c1, dtype=float)), p_c0)
    return np.linalg.inv(J.T @ J) * sigma_p_px ** 2
