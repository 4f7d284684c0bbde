"""Rotation angle helper shared by the metrics."""
from __future__ import annotations

import numpy as np


def angle_rad(R: np.ndarray) -> np.ndarray:
    """Angle (rad, in [0, pi]) of rotation matrices (...,3,3).

    Uses ``atan2(|vee(R - R^T)| / 2, (tr R - 1) / 2)``, accurate for small angles too
    (``arccos`` of the trace loses ~1e-8 rad near identity), so it agrees with evo's
    ``so3_log_angle`` to rounding.
    """
    R = np.asarray(R, dtype=float)
    v = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    s = 0.5 * np.linalg.norm(v, axis=-1)
    c = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    return np.arctan2(s, c)
