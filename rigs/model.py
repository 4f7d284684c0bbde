"""Rig definition: cameras, IMU, optional wheel encoders. Frozen, validated on construction.

Frames: ``b`` vehicle body, ``c0``/``c1`` cameras (OpenCV: x right, y down, z forward),
``i`` IMU. Extrinsics are ``T_b_c`` / ``T_b_i`` (4x4, nested tuples so the dataclass is
hashable and frozen). Noise densities are continuous-time, Kalibr units.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import cv2
import numpy as np

from rigs.errors import RigError

DIST_MODELS = ("radtan", "equidistant")

Matrix4 = tuple  # tuple of 4 tuples of 4 floats


def as_matrix4(value, where: str) -> Matrix4:
    """Validate a 4x4 rigid transform (nested sequence or array) -> nested tuple."""
    try:
        T = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise RigError(f"{where}: expected a 4x4 matrix of numbers, got {value!r}") from None
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise RigError(f"{where}: expected a finite 4x4 matrix, got shape {T.shape}")
    R = T[:3, :3]
    if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0.999 \
            or not np.allclose(T[3], [0, 0, 0, 1]):
        raise RigError(f"{where}: not a rigid transform (rotation not orthonormal or last row not 0 0 0 1)")
    return tuple(tuple(float(x) for x in row) for row in T)


def _positive(value, where: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise RigError(f"{where}: expected a number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise RigError(f"{where}: must be a positive finite number, got {value!r}")
    return v


def _nonneg(value, where: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise RigError(f"{where}: expected a number, got {value!r}") from None
    if not math.isfinite(v) or v < 0:
        raise RigError(f"{where}: must be a non-negative finite number, got {value!r}")
    return v


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
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    dist: tuple = (0.0, 0.0, 0.0, 0.0, 0.0)
    T_b_c: Matrix4 = field(default_factory=lambda: tuple(tuple(r) for r in np.eye(4).tolist()))
    dist_model: str = "radtan"

    def __post_init__(self):
        w = f"camera {self.name!r}"
        if self.dist_model not in DIST_MODELS:
            raise RigError(f"{w}.dist_model: expected one of {', '.join(DIST_MODELS)}, got {self.dist_model!r}")
        for f in ("width", "height"):
            v = getattr(self, f)
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v <= 0:
                raise RigError(f"{w}.{f}: must be a positive integer, got {v!r}")
            object.__setattr__(self, f, int(v))
        for f in ("fx", "fy"):
            object.__setattr__(self, f, _positive(getattr(self, f), f"{w}.{f}"))
        for f in ("cx", "cy"):
            v = getattr(self, f)
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise RigError(f"{w}.{f}: expected a number, got {v!r}") from None
            if not math.isfinite(v):
                raise RigError(f"{w}.{f}: must be finite, got {v!r}")
            size = self.width if f == "cx" else self.height
            if not 0.0 <= v <= size:
                raise RigError(f"{w}.{f}: principal point {v:g} px is outside the image (0 to {size} px, "
                               f"the camera's {'width' if f == 'cx' else 'height'})")
            object.__setattr__(self, f, v)
        d = tuple(float(x) for x in self.dist) if self.dist is not None else ()
        if self.dist_model == "equidistant":
            if len(d) != 4 or not all(math.isfinite(x) for x in d):
                raise RigError(f"{w}.dist: expected 4 finite equidistant coefficients (k1 k2 k3 k4), got {self.dist!r}")
            object.__setattr__(self, "dist", d)
            object.__setattr__(self, "T_b_c", as_matrix4(self.T_b_c, f"{w}.T_b_c"))
            return
        if len(d) == 4:
            d = d + (0.0,)
        if len(d) != 5 or not all(math.isfinite(x) for x in d):
            raise RigError(f"{w}.dist: expected 4 or 5 finite OpenCV coefficients (k1 k2 p1 p2 [k3]), got {self.dist!r}")
        object.__setattr__(self, "dist", d)
        object.__setattr__(self, "T_b_c", as_matrix4(self.T_b_c, f"{w}.T_b_c"))

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

    name: str = "ideal"
    rate_hz: float = 200.0
    accel_noise_density: float = 0.0     # m/s^2/sqrt(Hz)
    gyro_noise_density: float = 0.0      # rad/s/sqrt(Hz)
    accel_random_walk: float = 0.0       # m/s^3/sqrt(Hz)
    gyro_random_walk: float = 0.0        # rad/s^2/sqrt(Hz)
    T_b_i: Matrix4 = field(default_factory=lambda: tuple(tuple(r) for r in np.eye(4).tolist()))

    def __post_init__(self):
        w = f"imu {self.name!r}"
        object.__setattr__(self, "rate_hz", _positive(self.rate_hz, f"{w}.rate_hz"))
        for f in ("accel_noise_density", "gyro_noise_density", "accel_random_walk", "gyro_random_walk"):
            object.__setattr__(self, f, _nonneg(getattr(self, f), f"{w}.{f}"))
        object.__setattr__(self, "T_b_i", as_matrix4(self.T_b_i, f"{w}.T_b_i"))

    @property
    def T_b_i_array(self) -> np.ndarray:
        return np.array(self.T_b_i, dtype=float)


@dataclass(frozen=True)
class Wheels:
    """Wheel encoders on a differential-drive vehicle."""

    rate_hz: float = 50.0
    wheel_radius: float = 0.1          # m
    track_width: float = 0.5           # m, distance between left and right wheels
    ticks_per_rev: int = 1024
    slip_std: float = 0.0              # relative speed error (1 sigma)

    def __post_init__(self):
        for f in ("rate_hz", "wheel_radius", "track_width"):
            object.__setattr__(self, f, _positive(getattr(self, f), f"wheels.{f}"))
        object.__setattr__(self, "slip_std", _nonneg(self.slip_std, "wheels.slip_std"))
        if int(self.ticks_per_rev) <= 0:
            raise RigError(f"wheels.ticks_per_rev: must be a positive integer, got {self.ticks_per_rev!r}")


MIN_BASELINE_M = 1e-6      # two cameras closer than this share one position: no stereo geometry


@dataclass(frozen=True)
class Rig:
    """A stereo (or multi-camera) rig with an IMU. ``cameras[0]`` is the reference (left) camera."""

    name: str
    cameras: tuple
    imu: Imu = field(default_factory=Imu)
    camera_rate_hz: float = 20.0
    wheels: Optional[Wheels] = None
    mount: str = "mast"                # free-text: where the rig sits on the vehicle

    def __post_init__(self):
        cams = tuple(self.cameras)
        if len(cams) < 1 or not all(isinstance(c, Camera) for c in cams):
            raise RigError(f"rig {self.name!r}.cameras: expected at least one camera")
        names = [c.name for c in cams]
        if len(set(names)) != len(names):
            raise RigError(f"rig {self.name!r}.cameras: duplicate camera names {names}")
        object.__setattr__(self, "cameras", cams)
        object.__setattr__(self, "camera_rate_hz", _positive(self.camera_rate_hz, f"rig {self.name!r}.camera_rate_hz"))
        if not isinstance(self.imu, Imu):
            raise RigError(f"rig {self.name!r}.imu: expected an Imu")

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
