"""The yaw split of docs/studies/campus_yaw_walk.py against a trajectory built with known step errors.

A camera (z forward, y down) drives 50 straight steps of 1 m, turns 1 deg a step about its y axis for 30 steps, then
drives 20 straight steps. The estimate composes each true step with a known rotation error: +0.01 deg of yaw on each
straight step, -0.02 deg on each turning step, plus 0.005 deg of roll everywhere. The split must give the sums of
the yaw errors exactly (70 x 0.01 and 30 x -0.02 deg; float64 rounding only), the truth itself zero, and the drift
the end-point error over the path length.
"""
import numpy as np
from scipy.spatial.transform import Rotation

from tests.studies import load_study

walk = load_study("campus_yaw_walk")


def _step(yaw_deg: float, forward_m: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("y", yaw_deg, degrees=True).as_matrix()
    T[:3, 3] = (0.0, 0.0, forward_m)
    return T


def _trajectories():
    plan = [(0.0, 1.0)] * 50 + [(1.0, 1.0)] * 30 + [(0.0, 1.0)] * 20
    T_true, T_est = [np.eye(4)], [np.eye(4)]
    for yaw, forward in plan:
        step = _step(yaw, forward)
        error = np.eye(4)
        error[:3, :3] = Rotation.from_rotvec(np.radians([0.0, 0.01 if yaw == 0 else -0.02, 0.005])).as_matrix()
        T_true.append(T_true[-1] @ step)
        T_est.append(T_est[-1] @ step @ error)
    return np.array(T_est), np.array(T_true)


def test_the_split_sums_the_yaw_errors_of_straights_and_turns():
    T_est, T_true = _trajectories()
    r = walk.yaw_split(T_est, T_true)
    assert abs(r["yaw_straights_deg"] - 70 * 0.01) < 1e-9
    assert abs(r["yaw_turns_deg"] - 30 * -0.02) < 1e-9
    expected_rms = np.sqrt((70 * (0.01 ** 2 + 0.005 ** 2) + 30 * (0.02 ** 2 + 0.005 ** 2)) / 100)
    assert abs(r["rot_rms_deg"] - expected_rms) < 1e-9
    assert abs(r["drift_pct"] - 100 * np.linalg.norm(T_est[-1][:3, 3] - T_true[-1][:3, 3]) / 100.0) < 1e-9
    assert r["drift_pct"] > 0.1


def test_the_truth_has_no_error_and_the_first_pose_is_aligned():
    _, T_true = _trajectories()
    offset = _step(30.0, 5.0)
    r = walk.yaw_split(T_true, offset @ T_true)
    assert abs(r["yaw_straights_deg"]) < 1e-9 and abs(r["yaw_turns_deg"]) < 1e-9
    assert r["rot_rms_deg"] < 1e-9 and r["drift_pct"] < 1e-9
