"""Input and output records of the cross-site localizer, filled by a traverse reader or a test.

Frames: ``w`` world (z up), ``b`` rover body at a site (x forward, y left, z up, origin on the ground),
``c0``/``c1`` left/right OpenCV cameras of one stereo pair. Pose covariances are 6x6 over the
right-perturbation ``T = T_hat @ Exp(xi)``, ``xi = (rot_b [rad], trans_b [m])`` in the body frame
(gtsam's ``Pose3`` tangent order), so a BA marginal is used as is.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rigs.geometry import make_T, rot_y, rot_z
from vo.errors import VoError


def _matrix(value, shape, where: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.shape != shape or not np.all(np.isfinite(a)):
        raise VoError(f"{where}: expected a finite {shape} array, got shape {a.shape}")
    return a


@dataclass(frozen=True)
class StereoCal:
    """A rectified stereo camera: pinhole ``K`` (3,3) shared by both images (no lens distortion:
    rectify first), ``T_c0_c1`` (4,4) the right camera in the left camera frame (the relative
    orientation, pure translation along +x by the baseline), image ``width``/``height`` in pixels."""

    K: np.ndarray
    T_c0_c1: np.ndarray
    width: int
    height: int

    def __post_init__(self):
        object.__setattr__(self, "K", _matrix(self.K, (3, 3), "StereoCal.K"))
        T = _matrix(self.T_c0_c1, (4, 4), "StereoCal.T_c0_c1")
        object.__setattr__(self, "T_c0_c1", T)
        if not np.allclose(T[:3, :3], np.eye(3), atol=1e-9) or abs(T[1, 3]) + abs(T[2, 3]) > 1e-9 or T[0, 3] <= 0:
            raise VoError(f"StereoCal.T_c0_c1: expected a rectified pair (identity rotation, translation +x), "
                          f"got t = {T[:3, 3].round(6).tolist()}")
        for f in ("width", "height"):
            if int(getattr(self, f)) <= 0:
                raise VoError(f"StereoCal.{f}: must be a positive integer, got {getattr(self, f)!r}")

    @property
    def baseline(self) -> float:
        return float(self.T_c0_c1[0, 3])

    @property
    def f(self) -> float:
        return float(self.K[0, 0])


@dataclass(frozen=True)
class StereoPair:
    """One mast pointing: ``left``/``right`` (H,W) uint8 grey images and ``T_b_c0`` (4,4), the left
    camera in the body frame from the mast angles, ``T_b_mast @ R_z(pan) @ R_y(tilt) @ T_head_c``
    (CONVENTIONS.md, "Rovers and mounts"); ``pan_rad``/``tilt_rad`` are kept for reports only."""

    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)
    T_b_c0: np.ndarray
    pan_rad: float = 0.0
    tilt_rad: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "T_b_c0", _matrix(self.T_b_c0, (4, 4), "StereoPair.T_b_c0"))
        for f in ("left", "right"):
            im = np.asarray(getattr(self, f))
            if im.ndim != 2 or im.dtype != np.uint8:
                raise VoError(f"StereoPair.{f}: expected an (H,W) uint8 grey image, got {im.dtype} {im.shape}")


@dataclass(frozen=True)
class Site:
    """A rover stop: ``index`` (0-based, driving order), capture time ``t_ns`` (int64 ns), the stereo
    ``pairs`` of its partial panorama, the stereo calibration ``cal`` and the dead-reckoning prior
    ``T_w_b_prior`` (4,4) with covariance ``cov_prior`` (6,6, see the module docstring)."""

    index: int
    t_ns: int
    pairs: tuple
    cal: StereoCal
    T_w_b_prior: np.ndarray
    cov_prior: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "pairs", tuple(self.pairs))
        if not self.pairs or not all(isinstance(p, StereoPair) for p in self.pairs):
            raise VoError(f"Site {self.index}.pairs: expected one or more StereoPair")
        for p in self.pairs:
            if p.left.shape != (self.cal.height, self.cal.width) or p.right.shape != p.left.shape:
                raise VoError(f"Site {self.index}: image shape {p.left.shape} does not match the calibration "
                              f"({self.cal.height}, {self.cal.width})")
        object.__setattr__(self, "T_w_b_prior", _matrix(self.T_w_b_prior, (4, 4), f"Site {self.index}.T_w_b_prior"))
        C = _matrix(self.cov_prior, (6, 6), f"Site {self.index}.cov_prior")
        if not np.allclose(C, C.T, atol=1e-12) or np.linalg.eigvalsh(C).min() <= 0:
            raise VoError(f"Site {self.index}.cov_prior: must be symmetric positive definite")
        object.__setattr__(self, "cov_prior", C)


STATUSES = ("ok", "no_tie_points", "few_tie_points", "ambiguous")


@dataclass(frozen=True)
class SiteResult:
    """Localization of one site: ``status`` (one of :data:`STATUSES`), ``T_w_b`` (4,4) and ``cov``
    (6,6); on a status other than ``ok`` they are the dead-reckoning prior with the covariance
    inflated. ``n_tie_points`` after the outlier test; ``stats`` per-stage counts; ``timings_s``;
    ``ties`` the stage records (:class:`vo.crosssite.ties.TieSet`, regions and tie pixels) for figures."""

    index: int
    status: str
    T_w_b: np.ndarray
    cov: np.ndarray
    n_tie_points: int = 0
    stats: dict = field(default_factory=dict)
    timings_s: dict = field(default_factory=dict)
    reason: str = ""
    ties: object = field(default=None, repr=False, compare=False)


def mast_T_b_c(T_b_mast: np.ndarray, pan_rad: float, tilt_rad: float, T_head_c: np.ndarray) -> np.ndarray:
    """CONVENTIONS.md "Rovers and mounts": ``T_b_c = T_b_mast @ R_z(pan) @ R_y(tilt) @ T_head_c``
    (pan positive to the left about body z, tilt positive nose-down about the head's y)."""
    return np.asarray(T_b_mast, float) @ make_T(rot_z(pan_rad) @ rot_y(tilt_rad), np.zeros(3)) @ np.asarray(T_head_c, float)
