"""ASIFT feature matching between the left images of two sites (seed 001 §2.2), with the tilt set
reduced by the dead-reckoning prior.

ASIFT (Morel & Yu 2009) simulates views with tilts ``t = sqrt(2)^k`` and, per tilt, rolls in steps
of ``72 deg / t`` over [0, 180) and runs SIFT on each (``cv2.AffineFeature`` over ``cv2.SIFT``). The
prior predicts the transition tilt between the two views of the ground: the singular-value ratio of
the local affine map ``J_cur J_prev^-1`` where ``J`` is the Jacobian of ground-plane ``(x, y)`` ->
pixel at the overlap centre. Simulating tilts up to ``t`` on both images covers transition tilts up
to ``t^2`` (Morel & Yu), so only tilts up to the first ``sqrt(2)^k >= sqrt(tau)`` are simulated: the
paper's reduction of the tilt set (which it reports halves the matching time).
"""
from __future__ import annotations

import cv2
import numpy as np

from rigs.geometry import inv_T

SQRT2 = float(np.sqrt(2.0))


def plane_jacobian(T_w_c: np.ndarray, K: np.ndarray, p_w: np.ndarray) -> np.ndarray:
    """(2,2) d(u, v) / d(x_w, y_w) of a point moving on the horizontal plane through ``p_w``."""
    T_c_w = inv_T(T_w_c)
    P_c = T_c_w[:3, :3] @ p_w + T_c_w[:3, 3]
    x, y, z = P_c
    J_proj = np.array([[K[0, 0] / z, 0, -K[0, 0] * x / z ** 2], [0, K[1, 1] / z, -K[1, 1] * y / z ** 2]])
    return J_proj @ T_c_w[:3, :2]


def transition(T_w_c_prev, T_w_c_cur, K, p_w) -> tuple:
    """(transition tilt >= 1, scale cur/prev) between the two views of the ground at ``p_w``."""
    M = plane_jacobian(T_w_c_cur, K, p_w) @ np.linalg.inv(plane_jacobian(T_w_c_prev, K, p_w))
    s = np.linalg.svd(M, compute_uv=False)
    return float(s[0] / s[1]), float(np.sqrt(s[0] * s[1]))


def tilt_set(predicted_tilt: float, max_tilt: float) -> list:
    """ASIFT tilts ``sqrt(2)^k`` up to the first one >= ``sqrt(predicted_tilt)`` (at least up to
    sqrt 2), never beyond ``max_tilt``."""
    tilts = [1.0]
    need = max(np.sqrt(max(predicted_tilt, 1.0)), SQRT2)
    while tilts[-1] * SQRT2 <= max_tilt + 1e-9 and tilts[-1] < need - 1e-9:
        tilts.append(tilts[-1] * SQRT2)
    return tilts


def view_params(tilts) -> tuple:
    """Per-view (tilts, rolls in degrees) lists for ``AffineFeature.setViewParams``."""
    vt, vr = [], []
    for t in tilts:
        if t == 1.0:
            vt.append(1.0)
            vr.append(0.0)
            continue
        for r in np.arange(0.0, 180.0, 72.0 / t):
            vt.append(float(t))
            vr.append(float(r))
    return vt, vr


def detect(img: np.ndarray, mask, tilts, n_features: int, asift: bool = True, contrast: float = 0.04) -> tuple:
    """(keypoints uv (N,2), descriptors (N,128) float32) of ASIFT with ``tilts`` (plain SIFT when
    ``asift`` is False) inside ``mask``; ``contrast`` is SIFT's contrast threshold (low-contrast
    regolith needs less than OpenCV's 0.04)."""
    sift = cv2.SIFT_create(nfeatures=int(n_features), contrastThreshold=float(contrast))
    if asift:
        det = cv2.AffineFeature.create(sift)
        det.setViewParams(*view_params(tilts))
    else:
        det = sift
    kps, desc = det.detectAndCompute(img, mask)
    if desc is None or len(kps) == 0:
        return np.zeros((0, 2)), np.zeros((0, 128), np.float32)
    return np.array([k.pt for k in kps], float), np.asarray(desc, np.float32)


def match(desc_a: np.ndarray, desc_b: np.ndarray, ratio: float) -> np.ndarray:
    """(M,2) index pairs (a, b): Lowe's ratio test, then one match per b (the best)."""
    if len(desc_a) < 2 or len(desc_b) < 2:
        return np.zeros((0, 2), int)
    d1, d2, j1 = _two_nearest(desc_a, desc_b)
    best = {}
    for a in np.flatnonzero(d1 < ratio * d2):
        b = int(j1[a])
        if b not in best or d1[a] < best[b][1]:
            best[b] = (int(a), d1[a])
    return np.array(sorted((a, b) for b, (a, _) in best.items()), int).reshape(-1, 2)


MAX_TRAIN_ROWS = 1 << 17    # cv2.BFMatcher refuses a train set of 2^18 rows or more (IMGIDX_ONE)


def _two_nearest(desc_a: np.ndarray, desc_b: np.ndarray) -> tuple:
    """Per row of ``desc_a``: the nearest and second-nearest L2 distances in ``desc_b`` and the nearest's
    index ((N,), (N,), (N,)); ``desc_b`` matched in chunks of :data:`MAX_TRAIN_ROWS`. Second distance
    inf when ``desc_b`` has one row in reach."""
    n = len(desc_a)
    d = np.full((n, 4), np.inf)
    j = np.zeros((n, 4), int)
    matcher = cv2.BFMatcher(cv2.NORM_L2)
    for start in range(0, len(desc_b), MAX_TRAIN_ROWS):
        chunk = desc_b[start:start + MAX_TRAIN_ROWS]
        for m in matcher.knnMatch(desc_a, chunk, k=min(2, len(chunk))):
            for r, x in enumerate(m[:2]):
                d[x.queryIdx, 2 + r], j[x.queryIdx, 2 + r] = x.distance, start + x.trainIdx
        order = np.argsort(d, axis=1, kind="stable")
        d, j = np.take_along_axis(d, order, 1), np.take_along_axis(j, order, 1)
        d[:, 2:], j[:, 2:] = np.inf, 0
    return d[:, 0], d[:, 1], j[:, 0]
