"""ORB-SLAM2's close/far split for the stereo PnP (Mur-Artal & Tardos 2017, sec. III-A; not in seed 003).

Stereo depth error grows as ``z^2 / (f b)``: a disparity error ``e`` px makes a landmark ``e / d`` too far
along its ray, and a step fitted on landmarks at disparity ``d`` long by the same factor. Under a constant
calibration offset (the real KITTI excerpt's 1.4 px, docs/estimators.md) landmarks at 5-18 px disparity are
8-28 % long, those nearer than 40 baselines (> 18 px at f = 718 px) at most 8 %: a pose fitted on all of them
is long, and rejects most near landmarks as outliers, which then leave the tracks.

:func:`refine_on_near` refits a PnP pose with the near landmarks as 3-D points and the far ones as rays
(they give the rotation and the direction of travel, not the step length). :class:`NearFarGate` decides,
from the frames so far, whether the calibration is inconsistent enough for the split to be worth its cost:
with an exact calibration far landmarks carry real scale information (and selecting "near" landmarks by
their own noisy disparity biases them near), so the joint fit stands unless near and far landmarks disagree
on the step length by more than a disparity offset of ``calib_tolerance_px`` would make them at the
boundary disparity ``f / near_baselines``. Thresholds are in baselines and pixels, the same on every rig.
"""
from __future__ import annotations

import cv2
import numpy as np
from scipy.optimize import least_squares

from rigs.geometry import make_T, transform_points
from rigs.geometry.pinhole import project
from vo.estimators.pnp_core import PnpConfig, reprojection_errors


def _far_residuals(T_c0_o: np.ndarray, origin_o: np.ndarray, dir_o: np.ndarray, bearing: np.ndarray, f: float):
    """(M,) angle (times the focal length ``f``: ~px) between each observed bearing (M,3) and the plane through
    the current camera centre and the landmark's ray (from its birth camera centre ``origin_o`` (M,3) along
    the left camera's bearing at birth ``dir_o`` (M,3)): the epipolar constraint, independent of the
    landmark's depth along its ray (and of where stereo triangulation put it off that ray)."""
    a_c = transform_points(T_c0_o, origin_o)
    d_c = (T_c0_o[:3, :3] @ dir_o.T).T
    n = np.cross(a_c, d_c)
    n_norm = np.maximum(np.linalg.norm(n, axis=1), 1e-12)
    return f * np.einsum("ij,ij->i", n, bearing) / n_norm


def refine_on_near(T_c0_o: np.ndarray, inl: np.ndarray, near: np.ndarray | None, rays: tuple | None,
                   p_o, x, K, config: PnpConfig) -> tuple:
    """Refit the pose
    ``T_c0_o`` with the ``near`` (N,) bool landmarks (closer than ``config.near_baselines`` baselines when
    triangulated) as 3-D points (reprojection error) and the far inliers of ``inl`` (N,) as rays ``rays`` =
    ``(origin_o (N,3), dir_o (N,3))``: birth camera centre and left bearing at birth (epipolar error,
    :func:`_far_residuals`): far landmarks constrain
    the rotation and the direction of travel, near ones also the length of the step. Returns
    ``(T_c0_o, inliers)``: the far inliers as given, the near ones re-gated under the refitted pose.

    The near landmarks are selected at twice the gate around the joint fit (which is biased when they
    disagree with the far ones), then at the gate around the first refit. With fewer than
    ``config.min_near_inliers`` near landmarks in the gate, fewer than ``config.min_pnp_inliers`` far inliers,
    or ``near`` None, the joint fit stands. ``scipy.optimize.least_squares`` (LM) on the pose (rotation
    vector, translation)."""
    if near is None or rays is None or config.near_baselines <= 0:
        return T_c0_o, inl
    sel_f = inl & ~near
    if sel_f.sum() < config.min_pnp_inliers:
        return T_c0_o, inl
    f = float(K[0, 0])
    of, df = rays[0][sel_f], rays[1][sel_f]
    bf = np.c_[(x[sel_f] - K[:2, 2]) / np.diag(K)[:2], np.ones(int(sel_f.sum()))]
    bf /= np.linalg.norm(bf, axis=1, keepdims=True)

    def pose(v):
        return make_T(cv2.Rodrigues(v[:3].reshape(3, 1))[0], v[3:])

    T = T_c0_o
    for gate in (2.0 * config.ransac_reproj_px, config.ransac_reproj_px):
        sel_n = near & (reprojection_errors(T, p_o, x, K) < gate)
        if sel_n.sum() < config.min_near_inliers:
            return T_c0_o, inl
        pn, xn = p_o[sel_n], x[sel_n]

        def residuals(v):
            T_v = pose(v)
            return np.r_[(project(transform_points(T_v, pn), K) - xn).ravel(), _far_residuals(T_v, of, df, bf, f)]

        v0 = np.r_[cv2.Rodrigues(T[:3, :3])[0].ravel(), T[:3, 3]]
        try:
            T = pose(least_squares(residuals, v0, method="lm", x_scale="jac").x)
        except (ValueError, np.linalg.LinAlgError):
            return T_c0_o, inl
        if not np.all(np.isfinite(T)):
            return T_c0_o, inl
    return T, sel_f | (near & (reprojection_errors(T, p_o, x, K) < config.ransac_reproj_px))


class NearFarGate:
    """Whether the close/far split's pose replaces the joint one, from the frames so far: the far landmarks'
    excess step length ``sum(step_joint - step_split) / sum(step_split)`` (summed, so that frames standing
    still, whose ratio is noise, weigh nothing) against the scale a disparity offset of
    ``config.calib_tolerance_px`` makes at the boundary disparity ``d_n = f / near_baselines``
    (``tolerance / d_n``), once ``min_frames`` frames with a split and one stereo baseline of split steps
    were seen (before that the steps are too short for their ratio to mean anything). Both signs count (an
    offset of either sign makes far landmarks disagree)."""

    min_frames = 5

    def __init__(self, config: PnpConfig, f_px: float, baseline_m: float):
        self.baseline_m = baseline_m
        self.limit = config.calib_tolerance_px * config.near_baselines / f_px if config.near_baselines > 0 else np.inf
        self.n, self.sum_excess_m, self.sum_split_m = 0, 0.0, 0.0

    def use_split(self, step_joint_m: float, step_split_m: float) -> bool:
        self.n += 1
        self.sum_excess_m += step_joint_m - step_split_m
        self.sum_split_m += step_split_m
        return (self.n >= self.min_frames and self.sum_split_m >= self.baseline_m
                and abs(self.sum_excess_m / self.sum_split_m) > self.limit)
