"""Do the two trajectories track the same frame? A check on the rotation residual after alignment.

If the estimate tracks frame ``c`` (e.g. the left camera) and the ground truth frame ``b`` (e.g.
EuRoC's IMU/body frame), the estimate's rotation since the first pose is the truth's conjugated by
the constant ``R_b_c``: the same angle about a turned axis. After a first-pose (or any rigid)
alignment the rotation error then grows with every turn to tens of degrees, while translation
figures can look merely poor. We flag a rotation RMSE over :data:`MAX_ROT_RMSE_DEG`; when in
addition the angles turned since the first pose agree (conjugation keeps angles), the frames
differ almost surely, and the warning says so.
"""
from __future__ import annotations

import numpy as np

from vo.eval.rotation import angle_rad
from rigs.trajectory import Trajectory

MAX_ROT_RMSE_DEG = 5.0      # VO on our routes stays below 2 deg; frame mix-ups give tens of degrees
SAME_TURN_DEG = 1.0         # RMS difference of the angles turned since the first pose


def turned_deg(traj: Trajectory) -> np.ndarray:
    """(N,) angle (deg) of the rotation since the first pose, ``angle(R_0^T R_k)``: the same for any
    tracked frame rigidly attached to the vehicle."""
    return np.degrees(angle_rad(np.einsum("ji,njk->nik", traj.rotations[0], traj.rotations)))


def frame_warning(gt: Trajectory, est_aligned: Trajectory, rot_rmse_deg: float) -> str | None:
    """One-line warning when the rotation RMSE after alignment suggests different tracked frames."""
    if not rot_rmse_deg > MAX_ROT_RMSE_DEG:
        return None
    same_turns = float(np.sqrt(np.mean((turned_deg(gt) - turned_deg(est_aligned)) ** 2))) < SAME_TURN_DEG
    why = ("; the estimate turns by the same angles as the truth, about other axes" if same_turns else "")
    return (f"rotation error after alignment is {rot_rmse_deg:.1f} deg RMSE (over {MAX_ROT_RMSE_DEG:g}){why}: "
            f"the two trajectories probably track different frames. Likely cause: EuRoC ground truth "
            f"(state_groundtruth_estimate0) is the IMU/body frame, VO estimates are the left camera c0; "
            f"pass the dataset folder as --gt to evaluate the left camera")
