"""``DivergenceCheck``: when the sliding window has diverged, so that the estimator reinitialises.

VINS-Mono's ``failureDetection`` (run after every window optimisation) declares a failure on an accelerometer
bias above 2.5 m/s^2, a gyro bias above 1.0 rad/s, a step of the newest state of more than 5 m since the
previous frame, or more than 1 m of it vertical; its rotation test (50 deg) is computed but does not trigger
(``//return true`` in its code), and neither does its feature-count test; the same here. Two tests are added
for the gross failures the issue names, both from the estimate alone (no truth):

* velocity jump: the newest state's velocity after the optimisation against its IMU prediction from the
  previous frame's newest state (before this frame's optimisation). Over one frame interval the IMU
  predicts the velocity to a few cm/s; a correction of ``max_velocity_jump_mps`` means that the window
  re-estimated its whole motion (scale collapse, a wrong gravity).
* scale jump: the path length through the states the window held before this frame, as estimated before and
  after this frame's optimisation; a relative change above ``max_scale_jump`` in one frame is a rescaled
  window (measured on healthy runs in ``docs/vins.md``).

A failed optimisation (gtsam indeterminate system, cheirality) and a non-finite estimate are failures the
estimator catches itself. The thresholds are :class:`vo.vins.vins_config.VinsConfig` fields (``fail_*``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Snapshot:
    """The window at one instant: ``positions`` {state key: (3,) IMU position in w}, in window order;
    the newest state's ``velocity`` (3,), ``acc_bias`` (3,), ``gyr_bias`` (3,)."""

    positions: dict
    velocity: np.ndarray
    acc_bias: np.ndarray
    gyr_bias: np.ndarray


def path_length(positions: dict, keys) -> float:
    """Length of the polyline through ``positions[k]`` for ``keys`` in order (m)."""
    p = np.array([positions[k] for k in keys]).reshape(-1, 3)
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))


@dataclass(frozen=True)
class DivergenceCheck:
    """Thresholds (units in the names); ``min_path_m``: the scale test needs this much path to be meaningful."""

    max_acc_bias: float = 2.5
    max_gyr_bias: float = 1.0
    max_step_m: float = 5.0
    max_dz_m: float = 1.0
    max_velocity_jump_mps: float = 2.0
    max_scale_jump: float = 0.25
    min_path_m: float = 1.0

    def __call__(self, before: Snapshot, predicted_velocity: np.ndarray, after: Snapshot,
                 newest_key: int) -> str | None:
        """Reason the window diverged in words, or None. ``before``: the window before this frame (the previous
        newest state is its last key); ``predicted_velocity`` (3,): the IMU prediction of the newest state's
        velocity; ``after``: the window after this frame's optimisation, ``newest_key`` its newest state."""
        if np.linalg.norm(after.acc_bias) > self.max_acc_bias:
            return f"diverged: accelerometer bias {np.linalg.norm(after.acc_bias):.2f} > {self.max_acc_bias} m/s^2"
        if np.linalg.norm(after.gyr_bias) > self.max_gyr_bias:
            return f"diverged: gyro bias {np.linalg.norm(after.gyr_bias):.2f} > {self.max_gyr_bias} rad/s"
        prev_key = list(before.positions)[-1]
        step = after.positions[newest_key] - before.positions[prev_key]
        if np.linalg.norm(step) > self.max_step_m:
            return f"diverged: step {np.linalg.norm(step):.2f} > {self.max_step_m} m in one frame"
        if abs(step[2]) > self.max_dz_m:
            return f"diverged: vertical step {abs(step[2]):.2f} > {self.max_dz_m} m in one frame"
        dv = float(np.linalg.norm(after.velocity - predicted_velocity))
        if dv > self.max_velocity_jump_mps:
            return f"diverged: velocity jump {dv:.2f} > {self.max_velocity_jump_mps} m/s against the IMU prediction"
        common = [k for k in before.positions if k in after.positions]
        l0 = path_length(before.positions, common)
        if l0 >= self.min_path_m:
            ratio = path_length(after.positions, common) / l0
            if abs(ratio - 1.0) > self.max_scale_jump:
                return f"diverged: window scale changed by {100 * (ratio - 1):+.0f} % in one frame"
        return None
