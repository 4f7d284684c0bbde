"""Per-epoch records of the "rop" estimator: initial and adjusted motion of every solved epoch.

Seed 000's Fig. 5 claims that the network adjustment improves on the initial EOPs. To check it on
rendered data the estimator keeps, for every frame solved against its keyframe, the initial EOPs
(``"network"`` mode, the ones the adjustment starts from, and the paper's ``"minimal"`` reading)
and the adjusted ones, all as ``T_kf_c`` (current left camera in the keyframe's left camera).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from rigs.geometry import inv_T, rotation_angle


@dataclass(frozen=True)
class EpochRecord:
    """One solved epoch pair (keyframe ``t_ns_kf`` -> frame ``t_ns``).

    ``kind`` "rops" (four ROPs + adjustment) or "rotation_only" (no translation; the initial and
    adjusted transforms are then the same rotation-only fit). ``n_inliers``: pair -> inlier count of
    the ok ROPs. ``rops``: pair -> ``(R_i_j, rhat_i_j)`` of the ok ROPs (diagnostics)."""

    t_ns_kf: int
    t_ns: int
    kind: str
    T_kf_c_initial: np.ndarray
    T_kf_c_adjusted: np.ndarray
    T_kf_c_minimal: Optional[np.ndarray] = None
    n_inliers: dict = field(default_factory=dict)
    rops: dict = field(default_factory=dict)


def relative_pose_error(T_est: np.ndarray, T_true: np.ndarray) -> tuple[float, float]:
    """``(rotation error rad, position error m)`` of a relative pose ``T_kf_c`` against the truth."""
    D = inv_T(T_true) @ T_est
    return float(rotation_angle(D[:3, :3])), float(np.linalg.norm(T_est[:3, 3] - T_true[:3, 3]))


def true_relative(gt_T_w_c0: dict, rec: EpochRecord) -> np.ndarray:
    """True ``T_kf_c`` from ``{t_ns: T_w_c0}`` ground truth."""
    return inv_T(gt_T_w_c0[rec.t_ns_kf]) @ gt_T_w_c0[rec.t_ns]
