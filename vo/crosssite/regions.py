"""Initial matching regions from the dead-reckoning prior, seed 001 §2.1.

Forward-forward (same viewing direction): the current image's ground coverage (its pixel rays cut
with the ground plane of the current site, up to ``max_range_m``) is back-projected into the previous
site's image; each point's box margin is the prior's uncertainty propagated through its projection. Forward-backward: both images'
ground coverages are intersected on the ground plane, the overlap is extended by the uncertainty and
projected into each image. Boxes are ``(u0, v0, u1, v1)`` integer pixels, inclusive-exclusive.
"""
from __future__ import annotations

from typing import Optional

import cv2
import numpy as np

from rigs.geometry import inv_T, make_T, so3_exp


def ground_coverage(T_w_c: np.ndarray, K: np.ndarray, width: int, height: int, T_w_ground: np.ndarray,
                    max_range_m: float, n: int = 24) -> np.ndarray:
    """(M,3) world points where an ``n x n`` grid of pixel rays meets the ground plane (z = 0 of
    ``T_w_ground``, the site's body frame) within ``max_range_m`` of the camera."""
    u, v = np.meshgrid(np.linspace(0, width - 1, n), np.linspace(0, height - 1, n))
    rays_c = np.linalg.solve(K, np.vstack([u.ravel(), v.ravel(), np.ones(u.size)]))
    T_g_c = inv_T(T_w_ground) @ T_w_c
    d_g = T_g_c[:3, :3] @ rays_c
    o_g = T_g_c[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = -o_g[2] / d_g[2]
    hit = np.isfinite(lam) & (lam > 0) & (lam * np.linalg.norm(d_g, axis=0) <= max_range_m)
    P_g = o_g[:, None] + d_g[:, hit] * lam[hit]
    return (T_w_ground @ np.vstack([P_g, np.ones(P_g.shape[1])]))[:3].T


def project(T_w_c: np.ndarray, K: np.ndarray, P_w: np.ndarray) -> tuple:
    """(uv (M,2), depth (M,)) of world points in the camera ``T_w_c``."""
    P_c = (inv_T(T_w_c) @ np.c_[P_w, np.ones(len(P_w))].T)[:3].T
    z = P_c[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = (K[:2, :2] @ (P_c[:, :2] / z[:, None]).T).T + K[:2, 2]
    return uv, z


def prior_margin_px(cov6: np.ndarray, f: float, depth_m: float, n_sigma: float) -> float:
    """Pixel margin for a prior with 6x6 covariance (rot, trans): ``n_sigma (f s_rot + f s_trans / depth)``
    with the largest rotation and translation standard deviations."""
    s_rot = float(np.sqrt(np.linalg.eigvalsh(cov6[:3, :3]).max()))
    s_t = float(np.sqrt(np.linalg.eigvalsh(cov6[3:, 3:]).max()))
    return n_sigma * (f * s_rot + f * s_t / max(depth_m, 1e-3))


def box_of(uv: np.ndarray, z: np.ndarray, width: int, height: int, margin_px) -> Optional[tuple]:
    """Bounding box of the points in front of the camera, each extended by its ``margin_px`` (a
    scalar or one per point) and clipped; None if it misses the image."""
    ok = z > 0.1
    if not np.any(ok):
        return None
    m = np.broadcast_to(np.asarray(margin_px, float), z.shape)[ok][:, None]
    lo, hi = (uv[ok] - m).min(axis=0), (uv[ok] + m).max(axis=0)
    u0, v0 = max(0, int(np.floor(lo[0]))), max(0, int(np.floor(lo[1])))
    u1, v1 = min(width, int(np.ceil(hi[0])) + 1), min(height, int(np.ceil(hi[1])) + 1)
    return (u0, v0, u1, v1) if u1 - u0 >= 16 and v1 - v0 >= 16 else None


def pose_jacobian_px(project_fn, T_w_b: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """(M,2,6) numerical d uv / d xi of ``project_fn(T_w_b) -> uv (M,2)`` for the right perturbation
    ``T_w_b Exp(xi)``, ``xi = (rot, trans)`` (the prior covariance's tangent)."""
    uv0 = project_fn(T_w_b)
    J = np.empty((len(uv0), 2, 6))
    for k in range(6):
        xi = np.zeros(6)
        xi[k] = eps
        J[:, :, k] = (project_fn(T_w_b @ make_T(so3_exp(xi[:3]), xi[3:])) - uv0) / eps
    return J


def point_margins_px(project_fn, T_w_b: np.ndarray, cov6: np.ndarray, n_sigma: float) -> np.ndarray:
    """(M,) per-point pixel margins: ``n_sigma`` times the largest standard deviation of each point's
    pixel covariance ``J C J^T``, the prior covariance propagated through the projection point by point."""
    J = pose_jacobian_px(project_fn, T_w_b)
    C_uv = np.einsum("mik,kl,mjl->mij", J, cov6, J)
    lam = np.linalg.eigvalsh(0.5 * (C_uv + np.swapaxes(C_uv, 1, 2)))[:, -1]
    return n_sigma * np.sqrt(np.maximum(np.nan_to_num(lam, nan=0.0), 0.0))


def forward_forward(T_w_c_prev, T_w_c_cur, T_w_b_cur, cov_cur, K, width, height, max_range_m,
                    n_sigma) -> tuple:
    """-> (box in the previous image, box in the current image) or (None, None). The current
    coverage goes into the previous image; symmetrically the previous coverage into the current one.
    Each point's box margin is the prior covariance propagated through its own projection
    (:func:`point_margins_px`): the current coverage moves with the current pose in the previous
    image; the fixed previous coverage moves in the current image with the current camera."""
    cov_w = ground_coverage(T_w_c_cur, K, width, height, T_w_b_cur, max_range_m)
    cov_p = ground_coverage(T_w_c_prev, K, width, height, T_w_b_cur, max_range_m)
    if len(cov_w) == 0 or len(cov_p) == 0:
        return None, None
    P_b = (inv_T(T_w_b_cur) @ np.c_[cov_w, np.ones(len(cov_w))].T)[:3].T
    T_b_c = inv_T(T_w_b_cur) @ T_w_c_cur
    into_prev = lambda T: project(T_w_c_prev, K, (T @ np.c_[P_b, np.ones(len(P_b))].T)[:3].T)[0]  # noqa: E731
    into_cur = lambda T: project(T @ T_b_c, K, cov_p)[0]  # noqa: E731
    uv_p, z_p = project(T_w_c_prev, K, cov_w)
    uv_c, z_c = project(T_w_c_cur, K, cov_p)
    m_p = point_margins_px(into_prev, T_w_b_cur, cov_cur, n_sigma)
    m_c = point_margins_px(into_cur, T_w_b_cur, cov_cur, n_sigma)
    inside_p = _inside(uv_p, z_p, width, height, m_p)
    inside_c = _inside(uv_c, z_c, width, height, m_c)
    if not np.any(inside_p) or not np.any(inside_c):
        return None, None
    return (box_of(uv_p[inside_p], z_p[inside_p], width, height, m_p[inside_p]),
            box_of(uv_c[inside_c], z_c[inside_c], width, height, m_c[inside_c]))


def _inside(uv, z, width, height, margin):
    return (z > 0.1) & (uv[:, 0] > -margin) & (uv[:, 0] < width + margin) & \
           (uv[:, 1] > -margin) & (uv[:, 1] < height + margin)


def forward_backward(T_w_c_prev, T_w_c_cur, T_w_b_cur, cov_cur, K, width, height, max_range_m,
                     n_sigma) -> tuple:
    """-> (box prev, box cur) from the overlap of the two ground coverages (convex hulls on the ground
    plane, ``cv2.intersectConvexConvex``) extended by ``n_sigma`` (translation sigma + range x
    rotation sigma) metres, then projected into each image; (None, None) without overlap."""
    a = ground_coverage(T_w_c_prev, K, width, height, T_w_b_cur, max_range_m)
    b = ground_coverage(T_w_c_cur, K, width, height, T_w_b_cur, max_range_m)
    if len(a) < 3 or len(b) < 3:
        return None, None
    ha = cv2.convexHull(a[:, :2].astype(np.float32))
    hb = cv2.convexHull(b[:, :2].astype(np.float32))
    area, inter = cv2.intersectConvexConvex(ha, hb)
    if area <= 0 or inter is None:
        return None, None
    s_rot = float(np.sqrt(np.linalg.eigvalsh(cov_cur[:3, :3]).max()))
    s_t = float(np.sqrt(np.linalg.eigvalsh(cov_cur[3:, 3:]).max()))
    xy = inter.reshape(-1, 2).astype(float)
    c = xy.mean(axis=0)
    grow = n_sigma * (s_t + max_range_m * s_rot)
    d = xy - c
    xy = c + d * (1 + grow / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-6))
    z = np.full(len(xy), a[:, 2].mean())
    P = np.column_stack([xy, z])
    out = []
    for T in (T_w_c_prev, T_w_c_cur):
        uv, dz = project(T, K, P)
        out.append(box_of(uv, dz, width, height, 0.0))
    return tuple(out) if all(o is not None for o in out) else (None, None)


def box_mask(box: Optional[tuple], width: int, height: int) -> np.ndarray:
    """uint8 mask (255 inside the box)."""
    m = np.zeros((height, width), np.uint8)
    if box is not None:
        m[box[1]:box[3], box[0]:box[2]] = 255
    return m


def in_box(uv: np.ndarray, box: tuple) -> np.ndarray:
    return (uv[:, 0] >= box[0]) & (uv[:, 0] < box[2]) & (uv[:, 1] >= box[1]) & (uv[:, 1] < box[3])
