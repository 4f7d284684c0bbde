"""Seed 002 eq. 14-19: a feature as the inverse depth in its anchor camera, measured on the unit sphere.

A feature ``l`` first observed in window state ``a`` at normalized image point ``m_a = [x_a, y_a, 1]`` is the
point ``P_ca = m_a / rho`` (``rho`` the inverse of its depth along the anchor camera's optical axis, the
scalar of eq. 3). Its observation ``m_j`` in state ``j != a`` gives the residual (eq. 14-19, VINS-Mono's
``ProjectionFactor`` with the unit-sphere option)::

    P_cj = R_ci (R_j^T (R_a (R_ic P_ca + t_ic) + p_a - p_j) - t_ic)          # eq. 15-17
    r    = B_j^T (P_cj / |P_cj| - b_j),   b_j = m_j / |m_j|                    # eq. 18-19

with ``B_j`` (3x2) an orthonormal basis of the tangent plane of the sphere at ``b_j``; ``(R_a, p_a)`` and
``(R_j, p_j)`` the body (IMU) poses ``T_w_i``, ``(R_ic, t_ic)`` the camera in the IMU frame. ``r`` is an angle in
radians, so its standard deviation is ``pixel_sigma / F_c`` (1.5 / 460 by eq. 27) divided by the adaptive
weight. The paper prints eq. 19 as a difference of unit vectors without the tangent projection (3 rows, rank
2); the 2-row form is the one of the code it builds on and is the correct one for a 2-DoF measurement.
The anchor observation itself carries no residual (it defines the bearing), as in VINS-Mono.

The factor is a gtsam ``CustomFactor`` on keys (``X(a)``, ``X(j)``, ``L(l)``; ``L`` a 1-vector) with analytic
Jacobians in gtsam's Pose3 tangent convention ``T Exp([omega, v])`` (first order: ``R (I + [omega]x)``,
``p + R v``); ``tests/test_vins_inverse_depth.py`` checks them against central differences.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial

import gtsam
import numpy as np

from rigs.geometry import skew


def tangent_basis(b: np.ndarray) -> np.ndarray:
    """(2,3) rows: an orthonormal basis of the plane orthogonal to the unit vector ``b`` (3,)."""
    x, y, z = (float(v) for v in b)
    e1 = np.array([y, -x, 0.0]) if abs(z) < 0.9 else np.array([0.0, z, -y])     # b x e_z, else b x e_x
    e1 /= math.sqrt(e1 @ e1)
    return np.stack([e1, [y * e1[2] - z * e1[1], z * e1[0] - x * e1[2], x * e1[1] - y * e1[0]]])


@dataclass(frozen=True)
class _Observation:
    """Constants of one factor: ``Rm = R_ic m_a`` (3,), ``BT`` (2,3) tangent basis at ``b_j``, ``Bb = BT b_j``
    (2,), the extrinsics ``R_ic`` (3,3), ``t_ic`` (3,)."""

    Rm: np.ndarray
    BT: np.ndarray
    Bb: np.ndarray
    R_ic: np.ndarray
    t_ic: np.ndarray

    @classmethod
    def of(cls, xy_a, xy_j, T_i_c: np.ndarray) -> "_Observation":
        b_j = np.array([xy_j[0], xy_j[1], 1.0])
        b_j /= np.linalg.norm(b_j)
        T_i_c = np.asarray(T_i_c, float)
        BT = tangent_basis(b_j)
        return cls(T_i_c[:3, :3] @ np.array([xy_a[0], xy_a[1], 1.0]), BT, BT @ b_j, T_i_c[:3, :3].copy(),
                   T_i_c[:3, 3].copy())


def residual_and_jacobians(M_a: np.ndarray, M_j: np.ndarray, rho: float, ob: _Observation, want_H: bool):
    """Residual (2,) of eq. 19 and, if ``want_H``, its Jacobians (2,6), (2,6), (2,1) w.r.t. the anchor body
    pose ``M_a``, the observing body pose ``M_j`` (``T_w_i`` 4x4) and ``rho``."""
    R_a, R_j = M_a[:3, :3], M_j[:3, :3]
    P_ba = ob.Rm / rho + ob.t_ic
    q = (R_a @ P_ba + (M_a[:3, 3] - M_j[:3, 3])) @ R_j
    f = (q - ob.t_ic) @ ob.R_ic
    n = math.sqrt(f @ f)
    u = f / n
    Bu = ob.BT @ u
    r = Bu - ob.Bb
    if not want_H:
        return r, None
    A = (ob.BT - Bu[:, None] * u) @ (ob.R_ic.T / n)     # d r / d P_bj (d r / d P_cj = (BT - Bu u^T) / n)
    AjRa = A @ (R_j.T @ R_a)                           # d r / d (R_a^T P_w)
    H_a = np.hstack([AjRa @ skew(-P_ba), AjRa])
    H_j = np.hstack([A @ skew(q), -A])
    return r, (H_a, H_j, (AjRa @ ob.Rm).reshape(2, 1) / (-rho * rho))


def _error(ob: _Observation, this, values, jacobians):
    k = this.keys()
    r, H = residual_and_jacobians(values.atPose3(k[0]).matrix(), values.atPose3(k[1]).matrix(),
                                  values.atVector(k[2])[0], ob, jacobians is not None)
    if H is not None:
        jacobians[0], jacobians[1], jacobians[2] = H
    return r


def inverse_depth_factor(noise, key_a: int, key_j: int, key_l: int, xy_a, xy_j, T_i_c: np.ndarray):
    """The unit-sphere reprojection factor of a feature anchored at ``xy_a`` (normalized, state ``key_a``) and
    observed at ``xy_j`` (state ``key_j``); ``noise`` in radians (2-dim, robust or not)."""
    return gtsam.CustomFactor(noise, [key_a, key_j, key_l], partial(_error, _Observation.of(xy_a, xy_j, T_i_c)))


def inverse_depth_of(p_w: np.ndarray, T_w_ca: np.ndarray) -> float:
    """rho of the world point ``p_w`` (3,) in the anchor camera ``T_w_ca`` (4,4): 1 / its z (nan if behind)."""
    z = (np.linalg.inv(T_w_ca) @ np.append(np.asarray(p_w, float), 1.0))[2]
    return 1.0 / z if z > 0 else float("nan")


def point_of(rho: float, xy_a, T_w_ca: np.ndarray) -> np.ndarray:
    """World point (3,) of inverse depth ``rho`` on the anchor ray ``xy_a`` of camera ``T_w_ca`` (4,4)."""
    return T_w_ca[:3, :3] @ (np.array([xy_a[0], xy_a[1], 1.0]) / rho) + T_w_ca[:3, 3]
