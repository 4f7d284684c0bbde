"""THE one place for MuJoCo <-> OpenCV camera conventions.

Frames: OpenCV camera ``c`` (x right, y down, z forward = optical axis); MuJoCo camera
``mjcam`` (looks along its -z, y up, x right). ``R_mjcam_cv = diag(1, -1, -1)`` (a rotation of
pi about x), so ``T_b_mjcam = T_b_c @ T_cv_mjcam`` with ``T_cv_mjcam = diag(1, -1, -1, 1)``.

Intrinsics: MuJoCo's camera with ``sensorsize`` set renders an off-axis frustum from
``intrinsic = [fx_len, fy_len, px_len, py_len]`` (focal length and principal-point *offset from
the sensor centre*, all in length units). We use a sensor of ``width x height`` length units
(one unit per pixel), so ``intrinsic`` is in pixels. OpenCV puts pixel centres at integers, so the
image centre is at ``((W-1)/2, (H-1)/2)``; the offsets are measured from there. Signs were
determined experimentally (see tests/test_render_intrinsics.py): a positive MuJoCo principal
offset moves the image content towards -u and -v, i.e.
``px = (W-1)/2 - cx`` and ``py = (H-1)/2 - cy`` (both signs the same; the half-pixel term is
OpenGL's half-integer pixel centres vs OpenCV's integer ones).
"""
from __future__ import annotations

import numpy as np

from rigs.model import Camera
from rigs.geometry import R_from_quat_wxyz, quat_wxyz_from_R

R_MJCAM_CV = np.diag([1.0, -1.0, -1.0])   # R_mjcam_cv == R_cv_mjcam (its own inverse)
T_CV_MJCAM = np.diag([1.0, -1.0, -1.0, 1.0])


def T_b_mjcam(T_b_c: np.ndarray) -> np.ndarray:
    """(4,4) MuJoCo camera pose in ``b`` from the OpenCV camera pose ``T_b_c`` (4,4)."""
    return np.asarray(T_b_c, dtype=float) @ T_CV_MJCAM


def T_b_cv(T_b_mjc: np.ndarray) -> np.ndarray:
    """(4,4) OpenCV camera pose in ``b`` from a MuJoCo camera pose ``T_b_mjcam`` (inverse of above)."""
    return np.asarray(T_b_mjc, dtype=float) @ T_CV_MJCAM


def pos_quat_from_T(T_a_b: np.ndarray) -> tuple:
    """(pos (3,), quat_wxyz (4,)) of frame ``b`` in ``a``, MuJoCo's ``pos``/``quat`` (w, x, y, z)."""
    T_a_b = np.asarray(T_a_b, dtype=float)
    q = np.asarray(quat_wxyz_from_R(T_a_b[:3, :3]), dtype=float)
    if q[0] < 0:
        q = -q                                   # canonical hemisphere: w >= 0
    return T_a_b[:3, 3].copy(), q


def T_from_pos_quat(pos, quat_wxyz) -> np.ndarray:
    """(4,4) ``T_a_b`` from MuJoCo ``pos`` (3,) and ``quat`` (w, x, y, z)."""
    T = np.eye(4)
    T[:3, :3] = R_from_quat_wxyz(np.asarray(quat_wxyz, dtype=float))
    T[:3, 3] = np.asarray(pos, dtype=float)
    return T


def T_w_c_from_mj(cam_xpos, cam_xmat) -> np.ndarray:
    """(4,4) OpenCV ``T_w_c`` from MuJoCo ``data.cam_xpos[i]`` (3,) and ``data.cam_xmat[i]`` (9,)."""
    T = np.eye(4)
    T[:3, :3] = np.asarray(cam_xmat, dtype=float).reshape(3, 3)
    T[:3, 3] = cam_xpos
    return T @ T_CV_MJCAM


def mj_camera_intrinsics(camera: Camera) -> dict:
    """MjsCamera attributes reproducing ``camera``'s exact pinhole K (fx != fy, any cx, cy).

    Returns ``{"resolution": [W, H], "sensor_size": [W, H], "focal_pixel": [fx, fy],
    "principal_pixel": [px, py]}``
    with the sensor measured in pixels (see module docstring for the principal-point signs).
    """
    W, H = camera.width, camera.height
    px = (W - 1) / 2.0 - camera.cx
    py = (H - 1) / 2.0 - camera.cy
    return {
        "resolution": [W, H],
        "sensor_size": [float(W), float(H)],
        "focal_pixel": [camera.fx, camera.fy],
        "principal_pixel": [px, py],
    }


def apply_intrinsics(mjs_camera, camera: Camera) -> None:
    """Set ``mjs_camera`` (a ``mujoco.MjsCamera``) to ``camera``'s intrinsics."""
    for key, value in mj_camera_intrinsics(camera).items():
        setattr(mjs_camera, key, value)
