"""Where each tracked landmark should appear in the next image: the start points of ``klt-pnp``'s temporal LK.

Seed 003 starts its pyramidal LK (4 levels, 21x21 window) at zero flow, so a displacement is found only while
its coarsest level reaches it; at city speed with a lower frame rate (or a faster drive) most of the image
moves beyond that, and the backward LK of the forward-backward check, also started at zero flow, loses the
rest (``vo-testbed bench real --stride 3`` on `urban-kitti`: docs/estimators.md, "Frame rate"). The landmarks'
positions and the constant-velocity pose (the PnP's own motion prior) say where each track should be: that
prediction starts the forward LK, and its mirror the backward one (:func:`vo.frontend.klt.track_fb`), so the
round trip remains a test of the match. Not in seed 003.

Shapes: ``p_o`` (N,3) landmarks in the odometry frame; ``pts`` (N,2) current raw pixels; result (N,2) raw pixels.
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import inv_T, transform_points

MIN_DEPTH_M = 0.1     # a landmark nearer than this in front of the predicted camera keeps zero flow


def predicted_pixels(camera, T_o_c0_pred: np.ndarray, p_o: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """The landmarks ``p_o`` seen from the predicted pose ``T_o_c0_pred`` (4,4) through ``camera``'s lens model
    (:meth:`rigs.model.Camera.project`); a landmark behind that camera (or nearer than :data:`MIN_DEPTH_M`),
    not finite, or projecting outside the image keeps its current pixel ``pts`` (zero flow)."""
    pts = np.asarray(pts, np.float64).reshape(-1, 2)
    out = pts.copy()
    p_o = np.asarray(p_o, np.float64).reshape(-1, 3)
    if len(p_o) == 0:
        return out
    p_c = transform_points(inv_T(T_o_c0_pred), p_o)
    front = np.all(np.isfinite(p_c), axis=1) & (p_c[:, 2] > MIN_DEPTH_M)
    if front.any():
        uv = camera.project(p_c[front])
        inside = np.all(np.isfinite(uv), axis=1) & (uv[:, 0] >= 0) & (uv[:, 1] >= 0) \
            & (uv[:, 0] <= camera.width - 1) & (uv[:, 1] <= camera.height - 1)
        idx = np.flatnonzero(front)[inside]
        out[idx] = uv[inside]
    return out


def track_guess(camera, T_o_c0_pred: np.ndarray, landmarks: dict, ids: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """:func:`predicted_pixels` of the tracks ``ids`` (N,) at ``pts`` (N,2) whose landmark is in ``landmarks``
    (track id -> p_o (3,)); a track without one keeps its current pixel."""
    out = np.asarray(pts, np.float64).reshape(-1, 2).copy()
    have = np.array([int(i) in landmarks for i in ids], bool)
    if have.any():
        p_o = np.array([landmarks[int(i)] for i in np.asarray(ids)[have]])
        out[have] = predicted_pixels(camera, T_o_c0_pred, p_o, out[have])
    return out
