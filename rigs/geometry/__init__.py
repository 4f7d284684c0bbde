"""Rigid-body geometry helpers (pure numpy, no mujoco). Conventions: ../shared/CONVENTIONS.md."""
from rigs.geometry.se3 import (  # noqa: F401
    make_T, inv_T, transform_points, R_from_quat_wxyz, quat_wxyz_from_R,
    R_from_quat_xyzw, quat_xyzw_from_R, rot_x, rot_y, rot_z, R_from_opk_deg, opk_deg_from_R,
    skew, so3_exp, so3_log, rotation_angle, pose_error_left, pose_error_cov,
)
