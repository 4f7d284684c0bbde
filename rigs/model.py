"""Rig definition: cameras, IMU, optional wheel encoders. Frozen, validated on construction.

The classes are typed configurations (:mod:`rigs.typed_config`): each field's type and range is its
annotation and :func:`~rigs.typed_config.knob`, checked by :func:`~rigs.typed_config.check_fields`, so a rig
file (:mod:`rigs.rig_yaml`), a ``--set`` key (:mod:`rigs.overrides`) and code get one set of checks; the
checks that tie fields together (lens model and coefficients, principal point, rigid extrinsics) follow.

Frames: ``b`` vehicle body, ``c0``/``c1`` cameras (OpenCV: x right, y down, z forward),
``i`` IMU. Extrinsics are ``T_b_c`` / ``T_b_i`` (4x4, nested tuples so the dataclass is
hashable and frozen). Noise densities are continuous-time, Kalibr units.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Optional

import cv2
import numpy as np

from rigs.errors import RigError
from rigs.typed_config import check_fields, knob

DIST_MODELS = ("radtan", "equidistant")        # Camera.dist_model

Row4 = tuple[float, float, float, float]
Matrix4 = tuple[Row4, Row4, Row4, Row4]     # 4 rows of 4 floats: hashable, frozen


def _eye4() -> tuple:
    return tuple(tuple(r) for r in np.eye(4).tolist())


def rigid_problem(T) -> str | None:
    """Why the 4x4 ``T`` is not a rigid transform, or None."""
    T = np.asarray(T, dtype=float)
    R = T[:3, :3]
    if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0.999 \
            or not np.allclose(T[3], [0, 0, 0, 1]):
        return "not a rigid transform (rotation not orthonormal or last row not 0 0 0 1)"
    return None


def as_matrix4(value, where: str) -> Matrix4:
    """Validate a 4x4 rigid transform (nested sequence or array) -> nested tuple."""
    try:
        T = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise RigError(f"{where}: expected a 4x4 matrix of numbers, got {value!r}") from None
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise RigError(f"{where}: expected a finite 4x4 matrix, got shape {T.shape}")
    problem = rigid_problem(T)
    if problem:
        raise RigError(f"{where}: {problem}")
    return tuple(tuple(float(x) for x in row) for row in T)


@dataclass(frozen=True)
class Camera:
    """Pinhole camera with a lens model ``dist_model``:

    - ``radtan`` (default): OpenCV radial-tangential ``dist = (k1, k2, p1, p2, k3)``;
    - ``equidistant``: Kannala-Brandt fisheye, OpenCV ``cv2.fisheye``, Kalibr ``pinhole-equi``:
      ``dist = (k1, k2, k3, k4)``, ``theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)``,
      pixel = ``K [theta_d / r * x, theta_d / r * y, 1]`` for the ray ``(x, y, 1)``, ``r = |(x, y)|``,
      ``theta = atan(r)``. Rays up to (not including) 90 degrees off the axis.

    :meth:`project` / :meth:`undistort_normalized` dispatch on the model (``cv2.projectPoints`` /
    ``cv2.fisheye.projectPoints`` and their inverses). :attr:`dist_coeffs` is the radtan vector and refuses
    an equidistant camera, so code written for radtan fails loudly instead of misreading fisheye coefficients.
    """

    name: str
    width: int = knob(ge=1)
    height: int = knob(ge=1)
    fx: float = knob(gt=0.0)
    fy: float = knob(gt=0.0)
    cx: float = knob()
    cy: float = knob()
    dist: tuple[float, ...] = knob((0.0, 0.0, 0.0, 0.0, 0.0), required=True)
    T_b_c: Matrix4 = knob(default_factory=_eye4, required=True, check=rigid_problem)
    dist_model: Literal["radtan", "equidistant"] = "radtan"

    def __post_init__(self):
        w = f"camera {self.name!r}"
        check_fields(self, RigError, f"{w}.")
        for f in ("cx", "cy"):
            v, size = getattr(self, f), self.width if f == "cx" else self.height
            if not 0.0 <= v <= size:
                raise RigError(f"{w}.{f}: principal point {v:g} px is outside the image (0 to {size} px, "
                               f"the camera's {'width' if f == 'cx' else 'height'})")
        d = self.dist
        if self.dist_model == "equidistant":
            if len(d) != 4:
                raise RigError(f"{w}.dist: expected 4 finite equidistant coefficients (k1 k2 k3 k4), got {d!r}")
        else:
            d = d + (0.0,) if len(d) == 4 else d
            if len(d) != 5:
                raise RigError(f"{w}.dist: expected 4 or 5 finite OpenCV coefficients (k1 k2 p1 p2 [k3]), got {d!r}")
        object.__setattr__(self, "dist", d)

    @property
    def K(self) -> np.ndarray:
        """(3,3) intrinsic matrix."""
        return np.array([[self.fx, 0, self.cx], [0, self.fy, self.cy], [0, 0, 1.0]])

    @property
    def is_fisheye(self) -> bool:
        return self.dist_model == "equidistant"

    @property
    def dist_coeffs(self) -> np.ndarray:
        """(5,) OpenCV radtan distortion vector; a RigError for an equidistant camera (use
        :attr:`fisheye_coeffs`, :meth:`project`, :meth:`undistort_normalized`)."""
        if self.is_fisheye:
            raise RigError(f"camera {self.name!r}: an equidistant (fisheye) camera has no radtan coefficients; "
                           f"this step supports radtan cameras only")
        return np.array(self.dist, dtype=float)

    @property
    def fisheye_coeffs(self) -> np.ndarray:
        """(4,) ``cv2.fisheye`` vector ``(k1, k2, k3, k4)`` of an equidistant camera."""
        if not self.is_fisheye:
            raise RigError(f"camera {self.name!r}: not an equidistant camera")
        return np.array(self.dist, dtype=float)

    @property
    def has_distortion(self) -> bool:
        """True when the image is not the pinhole image of ``K`` (always for an equidistant camera)."""
        return self.is_fisheye or any(abs(x) > 0 for x in self.dist)

    def project(self, p_c: np.ndarray) -> np.ndarray:
        """(N,3) points in the camera frame (``z > 0``) -> (N,2) pixels through the lens model."""
        p = np.ascontiguousarray(np.asarray(p_c, dtype=np.float64).reshape(-1, 1, 3))
        if self.is_fisheye:
            uv, _ = cv2.fisheye.projectPoints(p, np.zeros((3, 1)), np.zeros((3, 1)), self.K, self.fisheye_coeffs)
        else:
            uv, _ = cv2.projectPoints(p, np.zeros(3), np.zeros(3), self.K, self.dist_coeffs)
        return uv.reshape(-1, 2)

    def undistort_normalized(self, uv: np.ndarray, iters: int = 30) -> np.ndarray:
        """(N,2) image pixels -> (N,2) normalised pinhole coordinates ``(x/z, y/z)`` (``cv2.undistortPoints`` /
        ``cv2.fisheye.undistortPoints``, at most ``iters`` iterations, stopping at 1e-14)."""
        p = np.ascontiguousarray(np.asarray(uv, dtype=np.float64).reshape(-1, 1, 2))
        crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, iters, 1e-14)
        if self.is_fisheye:
            xy = cv2.fisheye.undistortPoints(p, self.K, self.fisheye_coeffs, criteria=crit)
        else:
            xy = cv2.undistortPoints(p, self.K, self.dist_coeffs, criteria=crit)
        return xy.reshape(-1, 2)

    @property
    def T_b_c_array(self) -> np.ndarray:
        return np.array(self.T_b_c, dtype=float)


@dataclass(frozen=True)
class Imu:
    """IMU model: rate and the four Kalibr noise densities; extrinsic ``T_b_i``."""

    name: str = knob("ideal", required=True)
    rate_hz: float = knob(200.0, gt=0.0, required=True)
    accel_noise_density: float = knob(0.0, ge=0.0, required=True, doc="m/s^2/sqrt(Hz)")
    gyro_noise_density: float = knob(0.0, ge=0.0, required=True, doc="rad/s/sqrt(Hz)")
    accel_random_walk: float = knob(0.0, ge=0.0, required=True, doc="m/s^3/sqrt(Hz)")
    gyro_random_walk: float = knob(0.0, ge=0.0, required=True, doc="rad/s^2/sqrt(Hz)")
    T_b_i: Matrix4 = knob(default_factory=_eye4, required=True, check=rigid_problem)

    def __post_init__(self):
        check_fields(self, RigError, f"imu {self.name!r}.")

    @property
    def T_b_i_array(self) -> np.ndarray:
        return np.array(self.T_b_i, dtype=float)


@dataclass(frozen=True)
class Wheels:
    """Wheel encoders on a differential-drive vehicle."""

    rate_hz: float = knob(50.0, gt=0.0, required=True)
    wheel_radius: float = knob(0.1, gt=0.0, required=True, doc="m")
    track_width: float = knob(0.5, gt=0.0, required=True, doc="m, distance between left and right wheels")
    ticks_per_rev: int = knob(1024, ge=1, required=True)
    slip_std: float = knob(0.0, ge=0.0, required=True, doc="relative speed error (1 sigma)")

    def __post_init__(self):
        check_fields(self, RigError, "wheels.")


MIN_BASELINE_M = 1e-6      # two cameras closer than this share one position: no stereo geometry


@dataclass(frozen=True)
class Rig:
    """A stereo (or multi-camera) rig with an IMU. ``cameras[0]`` is the reference (left) camera."""

    name: str
    cameras: tuple[Camera, ...]
    imu: Imu = knob(default_factory=Imu, required=True)
    camera_rate_hz: float = knob(20.0, gt=0.0, required=True)
    wheels: Optional[Wheels] = knob(None, required=True)
    mount: str = knob("mast", required=True, doc="free-text: where the rig sits on the vehicle")

    def __post_init__(self):
        w = f"rig {self.name!r}"
        check_fields(self, RigError, f"{w}.")
        if not self.cameras:
            raise RigError(f"{w}.cameras: expected at least one camera")
        names = [c.name for c in self.cameras]
        if len(set(names)) != len(names):
            raise RigError(f"{w}.cameras: duplicate camera names {names}")

    @property
    def is_stereo(self) -> bool:
        return len(self.cameras) >= 2

    def check_stereo(self) -> "Rig":
        """``self``; a RigError when two cameras sit at one position (closer than :data:`MIN_BASELINE_M`):
        such a pair has no stereo geometry. Checked where a rig is read or data are generated (a test's
        stand-in rig built in code may put two cameras anywhere)."""
        cams = self.cameras
        for i in range(len(cams)):
            for j in range(i + 1, len(cams)):
                d = float(np.linalg.norm(cams[i].T_b_c_array[:3, 3] - cams[j].T_b_c_array[:3, 3]))
                if d < MIN_BASELINE_M:
                    raise RigError(f"rig {self.name!r}.cameras: {cams[i].name} and {cams[j].name} sit at the same "
                                   f"position (baseline {d:g} m); a stereo rig needs a baseline of at least "
                                   f"{MIN_BASELINE_M:g} m")
        return self

    def T_c0_c(self, k: int) -> np.ndarray:
        """(4,4) pose of camera ``k`` in the reference camera frame."""
        T_b_c0 = self.cameras[0].T_b_c_array
        T_b_ck = self.cameras[k].T_b_c_array
        return np.linalg.inv(T_b_c0) @ T_b_ck

    @property
    def T_c0_c1(self) -> np.ndarray:
        """(4,4) relative orientation (ROP) of the right camera; raises for a mono rig."""
        if not self.is_stereo:
            raise RigError(f"rig {self.name!r}: has one camera, no stereo baseline")
        return self.T_c0_c(1)

    @property
    def baseline(self) -> float:
        """Stereo baseline ``|t_c0_c1|`` in metres."""
        return float(np.linalg.norm(self.T_c0_c1[:3, 3]))
