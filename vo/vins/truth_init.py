"""Initialisation from ground truth (option ``init=truth``): an oracle start for comparing back-ends.

Where the monocular visual-inertial initialisation cannot observe the scale (a car accelerating on a straight
road: the keyframe positions of the up-to-scale SfM, differentiated twice, are noisier than the acceleration
that carries the scale; see docs/vins.md), the window can be started from the true keyframe poses and IMU
velocities of a simulated dataset (gravity-aligned world ``w``), zero biases, and landmarks triangulated from
the true poses. Everything after the start is the estimator's own. Real recordings have no such option.
"""
from __future__ import annotations

import numpy as np

from vo.errors import EstimatorError
from vo.vins.imu import GRAVITY
from vo.vins.sfm import _common, _triangulate
from vo.vins.vi_init import InitResult


class Truth:
    """True ``T_w_c`` (left camera) at frame times and IMU velocities in ``w`` of a dataset."""

    def __init__(self, dataset):
        gt_c = dataset.groundtruth_cam0() if dataset is not None else None
        gt_i = getattr(dataset, "groundtruth", None)
        if gt_c is None or gt_i is None or gt_i.frame != "i":
            raise EstimatorError("vins option init=truth: the dataset has no ground truth of cam0 and of the IMU "
                                 "(state_groundtruth_estimate0)")
        self.T_w_c = {int(t): T for t, T in zip(gt_c.t_ns, gt_c.T)}
        self.t_i, self.p_i = np.asarray(gt_i.t_ns, np.int64), gt_i.T[:, :3, 3]

    def velocity(self, t_ns: int) -> np.ndarray:
        """Central difference of the IMU-rate true positions around ``t_ns``."""
        k = int(np.clip(np.searchsorted(self.t_i, t_ns), 1, len(self.t_i) - 2))
        return (self.p_i[k + 1] - self.p_i[k - 1]) / ((self.t_i[k + 1] - self.t_i[k - 1]) * 1e-9)


def truth_init(truth: Truth, frames) -> InitResult:
    """InitResult in ``v = w`` (scale 1, gravity -z) for keyframes ``frames`` (FeatureFrames)."""
    missing = [f.t_ns for f in frames if f.t_ns not in truth.T_w_c]
    if missing:
        raise EstimatorError(f"vins option init=truth: no ground truth of cam0 at t_ns {missing[0]}")
    T_w_c = np.array([truth.T_w_c[f.t_ns] for f in frames])
    T_c_w = np.linalg.inv(T_w_c)
    v_w = np.array([truth.velocity(f.t_ns) for f in frames])
    points = {}
    for a in range(len(frames) - 1):
        for b in range(len(frames) - 1, a, -1):              # widest baseline first
            ids, xa, xb = _common(frames[a], frames[b])
            new = np.array([int(i) not in points for i in ids], bool)
            if not new.any():
                continue
            X, ok = _triangulate(T_c_w[a], T_c_w[b], xa[new], xb[new])
            for i, p, good in zip(ids[new], X, ok):
                if good:
                    points[int(i)] = p
    return InitResult(0, T_w_c[:, :3, :3], T_w_c[:, :3, 3], points, np.zeros(3), 1.0,
                      np.array([0.0, 0.0, -GRAVITY]), v_w)
