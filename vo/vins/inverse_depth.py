"""Seed 002 eq. 14-19: a feature as the inverse depth in its anchor camera, measured on the unit sphere.

A feature ``l`` first observed in window state ``a`` at normalized image point ``m_a = [x_a, y_a, 1]`` is the
point ``P_ca = m_a / rho`` (``rho`` the inverse of its depth along the anchor camera's optical axis, the
scalar of eq. 3). Its observation ``m_j`` in state ``j != a`` gives the residual (eq. 14-19, VINS-Mono's
``ProjectionFactor`` with the unit-sphere option)::

    P_cj = R_ci (R_j^T (R_a (R_ic P_ca + t_ic) + p_a - p_j) - t_ic)          # eq. 15-17
    r    = B_j^T (P_cj / |P_cj| - b_j) = B_j^T P_cj / |P_cj|,   b_j = m_j / |m_j|   # eq. 18-19

with ``B_j`` (3x2) an orthonormal basis of the tangent plane of the sphere at ``b_j``; ``(R_a, p_a)`` and
``(R_j, p_j)`` the body (IMU) poses ``T_w_i``, ``(R_ic, t_ic)`` the camera in the IMU frame. ``r`` is an angle in
radians, so its standard deviation is ``pixel_sigma / F_c`` (1.5 / 460 by eq. 27) divided by the adaptive
weight. The paper prints eq. 19 as a difference of unit vectors without the tangent projection (3 rows, rank
2); the 2-row form is the one of the code it builds on and is the correct one for a 2-DoF measurement.
The anchor observation itself carries no residual (it defines the bearing), as in VINS-Mono.

Two gtsam ``CustomFactor`` forms share :func:`residuals` (analytic Jacobians in gtsam's Pose3 tangent convention
``T Exp([omega, v])``, first order ``R (I + [omega]x)``, ``p + R v``; ``tests/test_vins_inverse_depth.py``
checks them against central differences):

* :func:`inverse_depth_factor`: one observation on keys (``X(a)``, ``X(j)``, ``L(l)``; ``L`` a 1-vector), with
  any gtsam noise model (robust or not);
* :func:`inverse_depth_group`: every observation in state ``j`` of the features anchored in ``a``, on keys
  (``X(a)``, ``X(j)``, ``L(l_1)``, ..., ``L(l_k)``), each observation with its own sigma and robust loss. It
  returns what gtsam's ``noiseModel.Robust`` would give each observation on its own: for linearization the
  whitened residual and Jacobians scaled by ``sqrt(w(|e|))`` (gtsam's block reweighting), for the error a
  residual of norm ``sqrt(2 rho(|e|))``, so that the factor's error is the sum of the robust losses. The
  estimator uses it because gtsam copies the whole ``Values`` into Python at every ``CustomFactor`` call
  inside its optimizers (about 70 ns per value: 18 us per call in a 260-variable window), so one call per
  (anchor, observer) pair instead of one per observation is what makes the parametrization real-time.
  ``tests/test_vins_inverse_depth.py`` checks that its linear system and error equal those of the
  single-observation factors with gtsam's robust noise models.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import gtsam
import numpy as np

from rigs.geometry import skew
from vo.vins import robust


def tangent_bases(b: np.ndarray) -> np.ndarray:
    """(k,2,3): rows of each an orthonormal basis of the plane orthogonal to the unit vector ``b[i]`` (k,3)."""
    b = np.asarray(b, float).reshape(-1, 3)
    x, y, z = b.T
    zero = np.zeros_like(x)
    e1 = np.where((np.abs(z) < 0.9)[:, None], np.stack([y, -x, zero], 1), np.stack([zero, z, -y], 1))
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)            # b x e_z, else b x e_x
    return np.stack([e1, (skew(b) @ e1[:, :, None])[:, :, 0]], axis=1)


def tangent_basis(b: np.ndarray) -> np.ndarray:
    """(2,3) rows: an orthonormal basis of the plane orthogonal to the unit vector ``b`` (3,)."""
    return tangent_bases(b)[0]


@dataclass(frozen=True)
class Observations:
    """Constants of k observations: ``Rm`` (k,3) = ``R_ic m_a``, ``G`` (k,2,3) = ``B_j^T R_ic^T`` (so that
    ``r = G s / |s|`` with ``s`` the point in the observer's IMU frame minus ``t_ic``), ``t_ic`` (3,)."""

    Rm: np.ndarray
    G: np.ndarray
    t_ic: np.ndarray

    @classmethod
    def of(cls, xy_a, xy_j, T_i_c: np.ndarray) -> "Observations":
        """From normalized anchor points ``xy_a`` (k,2), observations ``xy_j`` (k,2) and ``T_i_c`` (4,4)."""
        xy_a, xy_j = np.asarray(xy_a, float).reshape(-1, 2), np.asarray(xy_j, float).reshape(-1, 2)
        m_a, m_j = np.column_stack([xy_a, np.ones(len(xy_a))]), np.column_stack([xy_j, np.ones(len(xy_j))])
        R_ic = np.asarray(T_i_c, float)[:3, :3]
        BT = tangent_bases(m_j / np.linalg.norm(m_j, axis=1, keepdims=True))
        return cls(m_a @ R_ic.T, BT @ R_ic.T, np.asarray(T_i_c, float)[:3, 3].copy())


def residuals(M_a: np.ndarray, M_j: np.ndarray, rho: np.ndarray, ob: Observations, want_H: bool):
    """Residuals (k,2) of eq. 19 and, if ``want_H``, their Jacobians (k,2,6), (k,2,6), (k,2) w.r.t. the anchor
    body pose ``M_a``, the observing body pose ``M_j`` (``T_w_i`` 4x4) and each ``rho`` (k,)."""
    R_a, R_j = M_a[:3, :3], M_j[:3, :3]
    C = R_a.T @ R_j
    P_ba = ob.Rm / rho[:, None] + ob.t_ic                         # in the anchor IMU frame
    q = P_ba @ C + (M_a[:3, 3] - M_j[:3, 3]) @ R_j                 # in the observer IMU frame
    s = q - ob.t_ic
    n2 = np.einsum("ki,ki->k", s, s)
    n = np.sqrt(n2)
    Gs = (ob.G @ s[:, :, None])[:, :, 0]
    r = Gs / n[:, None]
    if not want_H:
        return r, None
    A = (ob.G - Gs[:, :, None] * (s / n2[:, None])[:, None, :]) / n[:, None, None]    # d r / d q
    AjRa = A @ C.T                                                 # d r / d (R_a^T P_w)
    H_a = np.concatenate([AjRa @ skew(-P_ba), AjRa], axis=2)
    H_j = np.concatenate([A @ skew(q), -A], axis=2)
    H_rho = (AjRa @ ob.Rm[:, :, None])[:, :, 0] / (-rho * rho)[:, None]
    return r, (H_a, H_j, H_rho)


def _poses_and_rho(this, values):
    k = this.keys()
    rho = np.array([values.atVector(key)[0] for key in k[2:]])
    return values.atPose3(k[0]).matrix(), values.atPose3(k[1]).matrix(), rho


def _single_error(ob: Observations, this, values, jacobians):
    r, H = residuals(*_poses_and_rho(this, values), ob, jacobians is not None)
    if H is not None:
        jacobians[0], jacobians[1], jacobians[2] = H[0][0], H[1][0], H[2][0].reshape(2, 1)
    return r[0]


def inverse_depth_factor(noise, key_a: int, key_j: int, key_l: int, xy_a, xy_j, T_i_c: np.ndarray):
    """The unit-sphere reprojection factor of a feature anchored at ``xy_a`` (normalized, state ``key_a``) and
    observed at ``xy_j`` (state ``key_j``); ``noise`` in radians (2-dim, robust or not)."""
    return gtsam.CustomFactor(noise, [key_a, key_j, key_l], partial(_single_error, Observations.of(xy_a, xy_j, T_i_c)))


@dataclass(frozen=True)
class _Group:
    ob: Observations
    sigma: np.ndarray          # (k,) radians
    kind: str                  # robust loss, vo.vins.robust.KINDS
    c: np.ndarray              # (k,) its thresholds (whitened units)


def _group_error(gr: _Group, this, values, jacobians):
    r, H = residuals(*_poses_and_rho(this, values), gr.ob, jacobians is not None)
    e = r / gr.sigma[:, None]
    norm = np.sqrt(np.einsum("ki,ki->k", e, e))
    if H is None:
        scale = np.sqrt(2.0 * robust.loss(gr.kind, gr.c, norm)) / np.maximum(norm, 1e-300)
        return (e * scale[:, None]).ravel()
    sw = np.sqrt(robust.weight(gr.kind, gr.c, norm))
    s = sw / gr.sigma
    k = len(s)
    jacobians[0] = (H[0] * s[:, None, None]).reshape(2 * k, 6)
    jacobians[1] = (H[1] * s[:, None, None]).reshape(2 * k, 6)
    H_rho = np.zeros((2 * k, k))
    H_rho.reshape(k, 2, k)[np.arange(k), :, np.arange(k)] = H[2] * s[:, None]
    for i in range(k):
        jacobians[2 + i] = H_rho[:, i:i + 1]
    return (e * sw[:, None]).ravel()


def inverse_depth_group(key_a: int, key_j: int, keys_l, xy_a, xy_j, T_i_c: np.ndarray, sigma, kind: str, c):
    """One factor for the k features ``keys_l`` anchored in ``key_a`` at ``xy_a`` (k,2) and observed in
    ``key_j`` at ``xy_j`` (k,2); per observation ``sigma`` (k,) radians and robust ``kind`` with thresholds
    ``c`` (k,)."""
    gr = _Group(Observations.of(xy_a, xy_j, T_i_c), np.asarray(sigma, float), kind,
                np.broadcast_to(np.asarray(c, float), (len(keys_l),)))
    return gtsam.CustomFactor(gtsam.noiseModel.Unit.Create(2 * len(keys_l)), [key_a, key_j, *keys_l],
                              partial(_group_error, gr))


def inverse_depth_of(p_w: np.ndarray, T_w_ca: np.ndarray) -> float:
    """rho of the world point ``p_w`` (3,) in the anchor camera ``T_w_ca`` (4,4): 1 / its z (nan if behind)."""
    z = (np.linalg.inv(T_w_ca) @ np.append(np.asarray(p_w, float), 1.0))[2]
    return 1.0 / z if z > 0 else float("nan")


def point_of(rho: float, xy_a, T_w_ca: np.ndarray) -> np.ndarray:
    """World point (3,) of inverse depth ``rho`` on the anchor ray ``xy_a`` of camera ``T_w_ca`` (4,4)."""
    return T_w_ca[:3, :3] @ (np.array([xy_a[0], xy_a[1], 1.0]) / rho) + T_w_ca[:3, 3]
