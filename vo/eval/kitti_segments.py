"""KITTI odometry devkit metric (``evaluate_odometry.cpp``): segment errors over fixed lengths."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vo.errors import VoError
from vo.eval.rotation import angle_rad
from rigs.geometry import inv_T
from rigs.trajectory import Trajectory

KITTI_LENGTHS_M = (100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0, 800.0)
STEP_SIZE = 10  # first frames every 10 frames, as the devkit


@dataclass(frozen=True)
class KittiResult:
    """Mean translational error (%) and rotational error (deg/m) over all segments.

    ``lengths_m`` are the segment lengths used (``scaled`` True when shortened to the route);
    ``per_length`` maps each length to ``(t_err_pct, r_err_deg_per_m, n_segments)``;
    ``segments`` (K,5): first, last, length, t_err (fraction), r_err (rad/m) for plots.
    """

    t_err_pct: float
    r_err_deg_per_m: float
    n_segments: int
    lengths_m: tuple
    scaled: bool
    per_length: dict
    segments: np.ndarray = field(repr=False)

    def to_dict(self) -> dict:
        return {"t_err_pct": self.t_err_pct, "r_err_deg_per_m": self.r_err_deg_per_m,
                "r_err_deg_per_100m": 100.0 * self.r_err_deg_per_m, "n_segments": self.n_segments,
                "lengths_m": list(self.lengths_m), "scaled": self.scaled,
                "per_length": {f"{k:g}": list(v) for k, v in self.per_length.items()}}


def route_lengths(path_length_m: float) -> tuple[tuple, bool]:
    """Devkit lengths 100..800 m if the route is at least 800 m long, else 10%..80% of the route
    (a zero-length route gives no lengths: :func:`kitti_errors` then reports NaN)."""
    if path_length_m >= KITTI_LENGTHS_M[-1]:
        return KITTI_LENGTHS_M, False
    return tuple(float(path_length_m * f / 10.0) for f in range(1, 9)), True


def _last_frame(dist: np.ndarray, first: int, length: float) -> int:
    """Devkit ``lastFrameFromSegmentLength``: first i >= first with dist[i] > dist[first] + length, or -1."""
    k = int(np.searchsorted(dist, dist[first] + length, side="right"))
    return k if k < dist.size else -1


def kitti_errors(gt: Trajectory, est: Trajectory, lengths=None, step_size: int = STEP_SIZE) -> KittiResult:
    """Devkit segment errors of associated trajectories (``lengths=None``: see :func:`route_lengths`).

    ``pose_error = inv(inv(P_i) P_j) @ (inv(Q_i) Q_j)`` as the devkit (P estimate, Q gt); its translation
    norm and angle equal those of the brief's ``inv(inv(Q_i) Q_j) @ inv(P_i) P_j``. ``t_err = |t| / len``,
    ``r_err = angle / len``. Distances are float64 here (the devkit uses float32).
    """
    if len(gt) != len(est) or len(gt) < 2:
        raise VoError(f"kitti_errors: gt and est must be associated with >= 2 poses, got {len(gt)} and {len(est)}")
    dist = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(gt.positions, axis=0), axis=1))])
    scaled = False
    if lengths is None:
        lengths, scaled = route_lengths(float(dist[-1]))
        if dist[-1] <= 0:                                  # standing still: no segment, NaN errors
            lengths = ()
    lengths = tuple(float(v) for v in lengths)
    if (not lengths and not scaled) or (lengths and min(lengths) <= 0):
        raise VoError(f"kitti_errors: segment lengths must be positive, got {lengths}")
    seg = []
    for first in range(0, len(gt), step_size):
        for L in lengths:
            last = _last_frame(dist, first, L)
            if last < 0:
                continue
            d_gt = inv_T(gt.T[first]) @ gt.T[last]
            d_est = inv_T(est.T[first]) @ est.T[last]
            E = inv_T(d_est) @ d_gt
            seg.append((first, last, L, np.linalg.norm(E[:3, 3]) / L, float(angle_rad(E[:3, :3])) / L))
    seg = np.array(seg, dtype=float).reshape(-1, 5)
    per = {L: (100.0 * float(seg[seg[:, 2] == L, 3].mean()), float(np.degrees(seg[seg[:, 2] == L, 4].mean())),
               int(np.sum(seg[:, 2] == L))) for L in lengths if np.any(seg[:, 2] == L)}
    t_pct = 100.0 * float(seg[:, 3].mean()) if len(seg) else float("nan")
    r_dpm = float(np.degrees(seg[:, 4].mean())) if len(seg) else float("nan")
    return KittiResult(t_pct, r_dpm, len(seg), lengths, scaled, per, seg)
