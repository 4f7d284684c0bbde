"""Zoom of the previous site's images before matching (seed 001 §2.2: "the images from the previous
site are also zoomed properly to compensate the scaling distortion caused by rover movement").

Per predicted region pair, the previous left image is resampled into the current image's geometry
by a 3x3 warp ``M`` (previous pixel -> current pixel) predicted from the dead-reckoning prior:

- ``scale``: the paper's zoom, a similarity of the predicted scale (:func:`vo.crosssite.asift.transition`
  at the overlap) that maps the previous region's centre onto the current region's centre;
- ``plane``: the homography the ground plane of the current site induces between the two cameras
  (an extension: it also removes the foreshortening, i.e. the transition tilt, that the scale alone
  leaves; with 20 deg down-looking Navcams and 8.5 m legs the ground is seen at scale 2-4 and
  transition tilt 2-8).

Features found in the warped image are mapped back to original previous-image pixels by ``M^-1``.
"""
from __future__ import annotations

from typing import Optional

import cv2
import numpy as np

from vo.crosssite import regions
from vo.crosssite.asift import transition


def plane_homography(T_w_c_prev, T_w_c_cur, T_w_ground, K, width, height, max_range_m) -> Optional[np.ndarray]:
    """3x3 map previous pixel -> current pixel induced by the plane z = 0 of ``T_w_ground`` (the
    current site's body frame), fitted to the current image's ground coverage; None with fewer than
    8 ground points seen by both cameras."""
    P_w = regions.ground_coverage(T_w_c_cur, K, width, height, T_w_ground, max_range_m)
    if len(P_w) < 8:
        return None
    uv_p, z_p = regions.project(T_w_c_prev, K, P_w)
    uv_c, z_c = regions.project(T_w_c_cur, K, P_w)
    ok = (z_p > 0.1) & (z_c > 0.1)
    if ok.sum() < 8:
        return None
    M, _ = cv2.findHomography(uv_p[ok], uv_c[ok], 0)
    return M if M is not None and np.all(np.isfinite(M)) else None


def scale_warp(box_prev, box_cur, scale: float) -> np.ndarray:
    """3x3 similarity: zoom by ``scale`` (current / previous) about the previous box centre onto the
    current box centre."""
    c_p = np.array([(box_prev[0] + box_prev[2]) / 2, (box_prev[1] + box_prev[3]) / 2])
    c_c = np.array([(box_cur[0] + box_cur[2]) / 2, (box_cur[1] + box_cur[3]) / 2])
    M = np.diag([scale, scale, 1.0])
    M[:2, 2] = c_c - scale * c_p
    return M


def pair_warp(prev, T_w_b_prev, cur, i: int, j: int, box_prev, box_cur, cfg) -> Optional[np.ndarray]:
    """The warp of previous pair ``i`` into current pair ``j`` for ``cfg.zoom`` (None: no zoom)."""
    K, W, H = cur.cal.K, cur.cal.width, cur.cal.height
    T_w_c_prev = T_w_b_prev @ prev.pairs[i].T_b_c0
    T_w_c_cur = cur.T_w_b_prior @ cur.pairs[j].T_b_c0
    if cfg.zoom == "plane":
        return plane_homography(T_w_c_prev, T_w_c_cur, cur.T_w_b_prior, K, W, H, cfg.region_max_range_m)
    if cfg.zoom == "scale":
        c = np.linalg.solve(K, [(box_cur[0] + box_cur[2]) / 2, (box_cur[1] + box_cur[3]) / 2, 1.0])
        d_w, o_w = T_w_c_cur[:3, :3] @ c, T_w_c_cur[:3, 3]
        if d_w[2] >= -1e-6:
            return None
        p_w = o_w + d_w * (cur.T_w_b_prior[2, 3] - o_w[2]) / d_w[2]
        return scale_warp(box_prev, box_cur, transition(T_w_c_prev, T_w_c_cur, K, p_w)[1])
    return None


def warp_image(img: np.ndarray, M: np.ndarray, width: int, height: int, erode_px: int = 4) -> tuple:
    """(warped image, uint8 mask of pixels with previous-image support, eroded by ``erode_px``)."""
    warped = cv2.warpPerspective(img, M, (width, height), flags=cv2.INTER_LINEAR)
    valid = cv2.warpPerspective(np.full(img.shape[:2], 255, np.uint8), M, (width, height), flags=cv2.INTER_NEAREST)
    if erode_px > 0:
        valid = cv2.erode(valid, np.ones((2 * erode_px + 1, 2 * erode_px + 1), np.uint8))
    return warped, valid


def unwarp_points(uv: np.ndarray, M: np.ndarray) -> np.ndarray:
    """(N,2) warped pixels -> original previous-image pixels."""
    if len(uv) == 0:
        return np.zeros((0, 2))
    return cv2.perspectiveTransform(np.asarray(uv, np.float64).reshape(1, -1, 2), np.linalg.inv(M))[0]
