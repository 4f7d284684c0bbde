"""Label-free test for stereo landmarks on depth edges (occlusion boundaries), shared by the stereo front-ends.

A corner where a near surface occludes a far one (a T-junction of their outlines) is not one surface point:
the stereo window straddles both depths, so its disparity lies between the two sides', and as the camera
moves the junction slides along the far surface, so its track follows no single 3-D point. Such landmarks
bias the pose one-sidedly (docs/estimators.md, "Depth-edge test").

The test looks at the disparity field around the corner, in the stereo pair itself: small-window stereo
matches (``win`` x ``win`` LK, one pyramid level, started at the landmark's own left-to-right offset) at
the corner ``p`` and at ``p + s u`` and ``p + 2 s u`` for the four directions ``u`` (left, right, up, down),
``s = win // 2 + 1`` (the shifted windows leave the corner pixel). With ``D(q)`` the 2-D offset
``right - left`` at ``q``, the one-sided second difference

    e_u = | D(p) - 2 D(p + s u) + D(p + 2 s u) |   (px)

vanishes on one plane (there the disparity is an affine function of the pixel, whatever the plane's slant:
ground, facades) and is the disparity step between the corner and that side on the far side of a boundary.
A landmark is rejected when ``max_u e_u`` exceeds ``threshold_px`` or the centre match itself fails; a
direction whose shifted matches fail (LK status 0, out of the image) gives no evidence. Thresholds are in
pixels of disparity, the same for every rig and scene scale. Optional sample gates (``min_eig``: smallest
eigenvalue of the window's gradient matrix; ``fb_px``: right -> left round trip) are off by default: on
``urban-dynamic`` they discard most of the edge evidence (ROC area against big-step edges, 15x5 windows: 0.54
with them, 0.85 without; docs/estimators.md "Depth-edge test", which also gives the drift measured with the test on:
it is off in the front-ends by default, ``KltConfig.edge_threshold_px = 0``).
"""
from __future__ import annotations

import cv2
import numpy as np

MIN_EIG = 0.0
FB_PX = np.inf
DIRECTIONS = np.array([(1, 0), (-1, 0), (0, 1), (0, -1)], dtype=np.float64)


def _offsets(left: np.ndarray, right: np.ndarray, q_l: np.ndarray, q_r0: np.ndarray, win: tuple,
             iters: int, eps: float, min_eig: float, fb_px: float) -> np.ndarray:
    """(M,2) right - left offsets of one-level ``win`` (width, height) LK matches of left pixels ``q_l`` started at
    ``q_r0``; NaN where a sample says nothing: LK fails, a window leaves either image, the left window's
    gradient matrix has a smallest eigenvalue below ``min_eig`` (OpenCV's normalisation: per pixel, grey
    levels / 255; too little texture, or texture in one direction only, pins no offset), or the right -> left
    match does not return within ``fb_px`` of ``q_l``."""
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, iters, eps)
    kw = dict(winSize=tuple(win), maxLevel=0, criteria=crit)
    a = q_l.astype(np.float32).reshape(-1, 1, 2)
    r, st, eig = cv2.calcOpticalFlowPyrLK(left, right, a, q_r0.astype(np.float32).reshape(-1, 1, 2).copy(),
                                          flags=cv2.OPTFLOW_USE_INITIAL_FLOW | cv2.OPTFLOW_LK_GET_MIN_EIGENVALS,
                                          **kw)
    back, st2, _ = cv2.calcOpticalFlowPyrLK(right, left, r, a.copy(), flags=cv2.OPTFLOW_USE_INITIAL_FLOW, **kw)
    r = r.reshape(-1, 2).astype(np.float64)
    h, w = right.shape[:2]
    hx, hy = win[0] // 2, win[1] // 2
    inside = lambda p: ((p[:, 0] >= hx) & (p[:, 1] >= hy) & (p[:, 0] <= w - 1 - hx)  # noqa: E731
                        & (p[:, 1] <= h - 1 - hy))
    ok = (st.reshape(-1) == 1) & (st2.reshape(-1) == 1) & np.all(np.isfinite(r), axis=1) & inside(r) & inside(q_l)
    ok &= eig.reshape(-1) >= min_eig
    ok &= np.linalg.norm(back.reshape(-1, 2) - q_l, axis=1) < fb_px
    return np.where(ok[:, None], r - q_l, np.nan)


def edge_score(left: np.ndarray, right: np.ndarray, p_left: np.ndarray, p_right: np.ndarray,
               win: int = 11, win_h: int = 11, iters: int = 30, eps: float = 0.01, min_eig: float = MIN_EIG,
               fb_px: float = FB_PX) -> np.ndarray:
    """(N,) largest one-sided second difference of the stereo offset around each left/right pair (px; see the
    module docstring); 0 where no direction could be measured, inf where the centre match itself fails.

    ``left``, ``right`` grey images (H,W) uint8; ``p_left``, ``p_right`` (N,2) raw pixels of the stereo pairs;
    ``win`` x ``win_h`` the sample window (px), ``iters``/``eps`` LK's stopping rule."""
    p_l = np.asarray(p_left, np.float64).reshape(-1, 2)
    n = len(p_l)
    if n == 0:
        return np.zeros(0)
    d_init = np.asarray(p_right, np.float64).reshape(-1, 2) - p_l
    s = np.array([win // 2 + 1, win_h // 2 + 1], np.float64)
    shifts = np.vstack([np.zeros((1, 2)), s * DIRECTIONS, 2 * s * DIRECTIONS])      # (9,2): centre, 1 s, 2 s
    q_l = (p_l[None, :, :] + shifts[:, None, :]).reshape(-1, 2)
    q_r0 = q_l + np.tile(d_init, (len(shifts), 1))
    D = _offsets(left, right, q_l, q_r0, (win, win_h), iters, eps, min_eig, fb_px).reshape(len(shifts), n, 2)
    e = np.abs(D[0][None, :, 0] - 2 * D[1:5, :, 0] + D[5:9, :, 0])                     # (4,N), NaN: no evidence
    score = np.where(np.isnan(e), -np.inf, e).max(axis=0)
    score = np.where(np.isfinite(score), score, 0.0)
    return np.where(np.any(np.isnan(D[0]), axis=1), np.inf, score)


def off_edge(left: np.ndarray, right: np.ndarray, p_left: np.ndarray, p_right: np.ndarray, config) -> np.ndarray:
    """(N,) bool: stereo pairs NOT on a depth edge under ``config`` (a :class:`vo.frontend.klt.KltConfig`:
    ``edge_win``, ``edge_win_h``, ``edge_threshold_px``; ``edge_threshold_px == 0`` turns the test off: all True)."""
    n = len(np.asarray(p_left).reshape(-1, 2))
    if config.edge_threshold_px <= 0 or n == 0:
        return np.ones(n, bool)
    score = edge_score(left, right, p_left, p_right, config.edge_win, config.edge_win_h, config.lk_iters,
                       config.lk_eps)
    return score <= config.edge_threshold_px
