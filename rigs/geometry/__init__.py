"""Low-level geometry on plain numpy arrays; imports nothing of ours. Conventions: ../shared/CONVENTIONS.md.

One module per concept: :mod:`~rigs.geometry.se3` (rigid transforms), :mod:`~rigs.geometry.rotation`
(SO(3), quaternions), :mod:`~rigs.geometry.pose_error` (pose errors and their sample covariance),
:mod:`~rigs.geometry.pinhole` (projection with OpenCV lens distortion and its inverse),
:mod:`~rigs.geometry.triangulation` (two-view triangulation).
"""
from rigs.geometry.se3 import make_T, inv_T, transform_points  # noqa: F401
from rigs.geometry.rotation import (  # noqa: F401
    R_from_quat_wxyz, quat_wxyz_from_R, R_from_quat_xyzw, quat_xyzw_from_R, rot_x, rot_y, rot_z,
    R_from_opk_deg, opk_deg_from_R, skew, so3_exp, so3_log, rotation_angle,
)
from rigs.geometry.pose_error import pose_error_left, pose_error_cov  # noqa: F401
