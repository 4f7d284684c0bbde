"""SO(3): rotation matrices, quaternions, elementary and omega-phi-kappa rotations, exp/log.

Quaternions only at I/O boundaries; each function names its order (``wxyz`` Hamilton or ``xyzw``).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def R_from_quat_wxyz(q_wxyz) -> np.ndarray:
    """Hamilton quaternion (w, x, y, z) (...,4) -> rotation matrix (...,3,3)."""
    q = np.asarray(q_wxyz, dtype=float)
    return Rotation.from_quat(q[..., [1, 2, 3, 0]]).as_matrix()


def quat_wxyz_from_R(R: np.ndarray) -> np.ndarray:
    """Rotation matrix (...,3,3) -> Hamilton quaternion (w, x, y, z), w >= 0."""
    q = Rotation.from_matrix(R).as_quat()[..., [3, 0, 1, 2]]
    return np.where(q[..., :1] < 0, -q, q)


def R_from_quat_xyzw(q_xyzw) -> np.ndarray:
    """Quaternion (x, y, z, w) as TUM and scipy write it -> rotation matrix."""
    return Rotation.from_quat(np.asarray(q_xyzw, dtype=float)).as_matrix()


def quat_xyzw_from_R(R: np.ndarray) -> np.ndarray:
    """Rotation matrix -> quaternion (x, y, z, w), w >= 0."""
    q = Rotation.from_matrix(R).as_quat()
    return np.where(q[..., 3:] < 0, -q, q)


def rot_x(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def R_from_opk_deg(omega_deg: float, phi_deg: float, kappa_deg: float) -> np.ndarray:
    """Photogrammetric omega-phi-kappa (degrees; rotations about X, Y, Z) -> R.

    Uses the usual photogrammetric sequence ``R = R_x(omega) @ R_y(phi) @ R_z(kappa)``
    (seed 000 Table 3 gives the relative rotation of the right camera this way).
    """
    o, p, k = np.radians([omega_deg, phi_deg, kappa_deg])
    return rot_x(o) @ rot_y(p) @ rot_z(k)


def opk_deg_from_R(R: np.ndarray) -> np.ndarray:
    """Inverse of :func:`R_from_opk_deg`: (3,3) -> (omega, phi, kappa) in degrees."""
    return np.degrees(Rotation.from_matrix(R).as_euler("XYZ"))


def skew(v) -> np.ndarray:
    """(..., 3) -> (..., 3, 3) cross-product matrices: ``skew(a) @ b = a x b``."""
    v = np.asarray(v, dtype=float)
    S = np.zeros(v.shape + (3,))
    S[..., 0, 1], S[..., 0, 2], S[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    S[..., 1, 0], S[..., 2, 0], S[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return S


def so3_exp(phi) -> np.ndarray:
    """Rotation vector (3,) -> rotation matrix (3,3)."""
    return Rotation.from_rotvec(np.asarray(phi, dtype=float)).as_matrix()


def so3_log(R: np.ndarray) -> np.ndarray:
    """Rotation matrix (3,3) -> rotation vector (3,)."""
    return Rotation.from_matrix(R).as_rotvec()


def rotation_angle(R: np.ndarray) -> np.ndarray:
    """Angle (rad) of rotation matrices (...,3,3), numerically safe."""
    c = (np.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0
    return np.arccos(np.clip(c, -1.0, 1.0))
