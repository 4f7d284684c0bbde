"""Matching two trajectories by timestamp, and interpolating a trajectory at given times."""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from vo.errors import VoError
from rigs.trajectory import Trajectory

DEFAULT_MAX_DIFF_NS = 10_000_000  # 10 ms, evo's default ``t_max_diff``


def associate(gt: Trajectory, est: Trajectory, max_diff_ns: int = DEFAULT_MAX_DIFF_NS
              ) -> tuple[Trajectory, Trajectory]:
    """Pair each estimate pose with the gt pose nearest in time, if within ``max_diff_ns``.

    Returns ``(gt_matched, est_matched)`` of equal length, one-to-one (a gt pose claimed by
    several estimate poses keeps only the closest), in time order. Raises VoError when no
    pair matches.
    """
    if max_diff_ns < 0:
        raise VoError(f"associate: max_diff_ns must be >= 0, got {max_diff_ns}")
    if len(gt) == 0 or len(est) == 0:
        raise VoError(f"associate: empty trajectory (gt {len(gt)} poses, est {len(est)} poses)")
    i_gt, i_est = _nearest_pairs(gt.t_ns, est.t_ns, int(max_diff_ns))
    if i_gt.size == 0:
        raise VoError(f"associate: no timestamps match within {max_diff_ns} ns "
                      f"(gt {gt.t_ns[0]}..{gt.t_ns[-1]}, est {est.t_ns[0]}..{est.t_ns[-1]})")
    return gt.subset(i_gt), est.subset(i_est)


def _nearest_pairs(t_gt: np.ndarray, t_est: np.ndarray, max_diff_ns: int) -> tuple[np.ndarray, np.ndarray]:
    """(M,), (N,) sorted int64 -> index arrays (K,) of one-to-one nearest matches."""
    k = np.clip(np.searchsorted(t_gt, t_est), 1, max(len(t_gt) - 1, 1))
    lo = k - 1 if len(t_gt) > 1 else np.zeros_like(k)
    hi = k if len(t_gt) > 1 else np.zeros_like(k)
    d_lo, d_hi = np.abs(t_est - t_gt[lo]), np.abs(t_gt[hi] - t_est)
    i_gt = np.where(d_hi < d_lo, hi, lo)
    d = np.minimum(d_lo, d_hi)
    i_est = np.flatnonzero(d <= max_diff_ns)
    i_gt, d = i_gt[i_est], d[i_est]
    order = np.lexsort((d, i_gt))                      # per gt index, closest first
    _, first = np.unique(i_gt[order], return_index=True)
    keep = np.sort(order[first])
    return i_gt[keep], i_est[keep]


def interpolate(traj: Trajectory, t_ns) -> Trajectory:
    """Poses of ``traj`` at strictly increasing times ``t_ns`` (K,) inside its time range
    (linear position, SLERP rotation) as a Trajectory; see :func:`interpolate_T`."""
    t_q = np.atleast_1d(np.asarray(t_ns, dtype=np.int64))
    return Trajectory(t_q, interpolate_T(traj, t_q), traj.ref, traj.frame)


def interpolate_T(traj: Trajectory, t_ns) -> np.ndarray:
    """(K,) int64 times (any order) -> (K,4,4) poses ``T_ref_frame``: linear position, SLERP rotation.

    Raises VoError for a time outside ``[traj.t_ns[0], traj.t_ns[-1]]``.
    """
    t_q = np.atleast_1d(np.asarray(t_ns, dtype=np.int64))
    if len(traj) == 0 or np.any(t_q < traj.t_ns[0]) or np.any(t_q > traj.t_ns[-1]):
        bad = t_q[(t_q < traj.t_ns[0]) | (t_q > traj.t_ns[-1])] if len(traj) else t_q
        raise VoError(f"interpolate: time {int(bad[0])} ns outside trajectory range "
                      f"{traj.t_ns[0] if len(traj) else '-'}..{traj.t_ns[-1] if len(traj) else '-'} ns")
    T = np.tile(np.eye(4), (t_q.size, 1, 1))
    if len(traj) == 1:
        T[:] = traj.T[0]
        return T
    t_rel = (traj.t_ns - traj.t_ns[0]).astype(float)   # relative times keep ns precision in float64
    q_rel = (t_q - traj.t_ns[0]).astype(float)
    for a in range(3):
        T[:, a, 3] = np.interp(q_rel, t_rel, traj.positions[:, a])
    T[:, :3, :3] = Slerp(t_rel, Rotation.from_matrix(traj.rotations))(q_rel).as_matrix()
    return T
