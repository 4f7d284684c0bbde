"""A disparity prior for stereo LK: where to start the right-image search of new corners.

Pyramidal LK finds a stereo match from zero disparity only where the coarse pyramid levels hold
structure: in a nearly blank view (a white wall with a few pen strokes) under the ``realistic``
camera (darker image after auto exposure, shot noise), the coarse levels are noise, LK stays near
its start and the 40-50 px disparities of the wall are not found (``indoor-realistic`` seed 0, frames
222-234: 25-47 of 150-190 corners matched from zero disparity; 56-101 when started at 40 px). ``klt-pnp``
knows the disparities of the points it already has: its landmarks projected into both cameras at the
current pose. A new corner's right-image search starts at the median disparity vector of its ``k``
nearest such points in the left image. :func:`vo.frontend.klt.stereo_klt` tries the prior only for the
corners whose search from zero disparity fails the forward-backward or the epipolar check, with the same
checks. Not in seed 003; off by default (``KltConfig.stereo_prior``): on ``indoor-realistic`` it gave
``klt-pnp`` 4.45 / 6.98 % on seeds 0 / 11 against 7.77 / 7.13 % without, but 10.37 % against 5.46 % on the
held-out seed 23 (docs/estimators.md, "Calibration row offset and blank views").

Shapes: points (N,2) raw pixels ``(u, v)``; landmarks (M,3); transforms (4,4).
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import inv_T, transform_points
from vo.frontend.stereo import project


def disparity_guess(p_new: np.ndarray, ref_left: np.ndarray, ref_right: np.ndarray, k: int = 8,
                    min_refs: int = 5) -> np.ndarray | None:
    """(N,2) right-image start points ``p_new + median (ref_right - ref_left)`` over the ``k`` reference
    pairs nearest each new point in the left image; None when there are fewer than ``min_refs`` references."""
    p_new = np.asarray(p_new, np.float64).reshape(-1, 2)
    ref_left = np.asarray(ref_left, np.float64).reshape(-1, 2)
    d = np.asarray(ref_right, np.float64).reshape(-1, 2) - ref_left
    if len(ref_left) < min_refs or len(p_new) == 0:
        return None
    k = min(k, len(ref_left))
    dist = np.sum((p_new[:, None, :] - ref_left[None, :, :]) ** 2, axis=2)       # (N, M)
    near = np.argpartition(dist, k - 1, axis=1)[:, :k]
    return p_new + np.median(d[near], axis=1)


def landmark_refs(rig, T_c0_o: np.ndarray, p_o: np.ndarray, pts_left: np.ndarray) -> tuple:
    """Reference pairs from landmarks: their tracked left pixels ``pts_left`` (M,2) and their projection
    into the right camera (pinhole K, no distortion: a start point needs no better) -> ``(ref_left, ref_right)``,
    only landmarks in front of both cameras."""
    p_o = np.asarray(p_o, np.float64).reshape(-1, 3)
    if len(p_o) == 0:
        return np.zeros((0, 2)), np.zeros((0, 2))
    p_c0 = transform_points(T_c0_o, p_o)
    p_c1 = transform_points(inv_T(rig.T_c0_c1), p_c0)
    front = (p_c0[:, 2] > 1e-6) & (p_c1[:, 2] > 1e-6)
    return np.asarray(pts_left, np.float64).reshape(-1, 2)[front], project(p_c1[front], rig.cameras[1])
