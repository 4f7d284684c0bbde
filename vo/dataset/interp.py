"""Pose interpolation at query times: linear in position, SLERP in rotation."""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from rigs.trajectory import Trajectory


def interpolate_poses(traj: Trajectory, t_query_ns: np.ndarray) -> tuple[Trajectory, np.ndarray]:
    """Poses of ``traj`` at ``t_query_ns`` (int64, increasing) inside ``traj``'s time range.

    Returns ``(Trajectory at the kept times, keep mask (Q,) bool)``; queries outside
    ``[t_ns[0], t_ns[-1]]`` are dropped (no extrapolation).
    """
    tq = np.asarray(t_query_ns, dtype=np.int64)
    keep = (tq >= traj.t_ns[0]) & (tq <= traj.t_ns[-1]) if len(traj) else np.zeros(len(tq), bool)
    tq = tq[keep]
    if len(tq) == 0:
        return Trajectory(np.zeros(0, np.int64), np.zeros((0, 4, 4)), traj.ref, traj.frame), keep
    t0 = traj.t_ns[0]
    ts = (traj.t_ns - t0).astype(float)        # relative ns as float: exact below 2^53 ns (104 days)
    tqs = (tq - t0).astype(float)
    T = np.tile(np.eye(4), (len(tq), 1, 1))
    for k in range(3):
        T[:, k, 3] = np.interp(tqs, ts, traj.positions[:, k])
    if len(traj) == 1:
        T[:, :3, :3] = traj.rotations[0]
    else:
        T[:, :3, :3] = Slerp(ts, Rotation.from_matrix(traj.rotations))(tqs).as_matrix()
    return Trajectory(tq, T, traj.ref, traj.frame), keep
