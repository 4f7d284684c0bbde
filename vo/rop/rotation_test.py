"""The ROP step's rotation against the track filter's PnP rotation, in the metric of their covariances.

Our extension (seed 000 trusts every adjusted step and has no second estimate to test it against). Each
frame has two estimates of the keyframe -> current rotation ``R_kf_c`` from the same tracks: the ROP
adjustment's (seed 000, eqs. 1-3; its first-order covariance ``cov_step[:3, :3]`` of a rotation vector with
the left perturbation ``R = exp(dphi) R_hat``, :mod:`vo.rop.adjustment`) and the PnP fit of the keyframe's
stereo points (:mod:`vo.rop.moving`). Their difference, as the rotation vector ``r = log(R_rop^T R_pnp)`` in
the current camera frame (right perturbation), is tested with

    ``d2 = r^T (C_rop + C_pnp)^-1 r``  against  ``chi2_3(prob)``

where ``C_rop = R_rop^T C_left R_rop`` (the adjustment's covariance moved to the right perturbation) and
``C_pnp = s^2 (J^T J)^-1[rot]`` the PnP fit's first-order covariance (``J`` the Jacobian of the inliers'
reprojections with respect to a left perturbation of ``R_c_kf``, the translation free, the keyframe points
held fixed; ``s^2`` the residual variance ``sum |e|^2 / (2n - 6)``). Under the hypothesis that both are
unbiased with these covariances and independent, ``d2`` is chi-square with 3 degrees of freedom, so the test
fires with probability ``1 - prob`` on a correct pair (checked against exact truth in
``tests/test_rop_rotation_test.py``). The two fits share the image noise of the same tracks; positively
correlated errors make the sum of covariances larger than that of the difference, and the test conservative.
The first-order covariances are optimistic by a factor common to a recording (:class:`RotationTester` estimates
it from the run, as seed 000's a-posteriori variance factor rescales its adjustment). Seed 000 speaks to neither
covariance's use here; the test, its probability, the variance factor and what a failed step becomes
(:func:`readjusted_step`) are beyond the paper. Figures: docs/estimators.md, "The rotation test".
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.stats import chi2

from rigs.geometry import inv_T, make_T, so3_log
from vo.rop.adjustment import AdjustmentConfig, adjust_translations
from vo.frontend.stereo import triangulate, undistort_px

MIN_POINTS = 6              # PnP inliers needed for a covariance (6 unknowns)
DOF = 3                     # rotation vector
MIN_FACTOR_STEPS = 5        # tested steps before the variance factor is estimated (and the test acts)
CHI2_MEDIAN = float(chi2.median(DOF))   # 2.366


@dataclass(frozen=True)
class RotationTest:
    """``d2`` Mahalanobis distance squared, ``threshold`` ``chi2_3(prob)``, ``angle_deg`` ``|r|``; ``fires``."""

    d2: float
    threshold: float
    angle_deg: float

    @property
    def fires(self) -> bool:
        return bool(self.d2 > self.threshold)


@lru_cache(maxsize=8)
def chi2_threshold(prob: float) -> float:
    """``chi2_3`` quantile at ``prob`` (e.g. 11.34 at 0.99)."""
    return float(chi2.ppf(prob, DOF))


def pnp_rotation_cov(p_kf: np.ndarray, x_px: np.ndarray, K: np.ndarray, T_kf_c: np.ndarray,
                     inlier_px: float) -> np.ndarray | None:
    """(3,3) first-order covariance (rad^2) of the PnP rotation, right perturbation of ``R_kf_c`` (= left
    perturbation of ``R_c_kf`` up to sign), from the keyframe points ``p_kf`` (N,3), their undistorted pixels
    ``x_px`` (N,2) in the current image, intrinsics ``K`` (3,3), the fitted ``T_kf_c`` (4,4): the inliers within
    ``inlier_px``, ``J`` (2n,6) with respect to ``(dphi, dt)`` of ``p_c = exp(dphi) (R_c_kf p + t) + dt``.
    None with fewer than :data:`MIN_POINTS` inliers or a singular ``J^T J``."""
    T_c_kf = inv_T(np.asarray(T_kf_c, float))
    p_c = p_kf @ T_c_kf[:3, :3].T + T_c_kf[:3, 3]
    z = p_c[:, 2]
    front = z > 1e-6
    fx, fy = float(K[0, 0]), float(K[1, 1])
    u = np.full(len(p_c), np.nan)
    v = np.full(len(p_c), np.nan)
    u[front] = fx * p_c[front, 0] / z[front] + K[0, 2]
    v[front] = fy * p_c[front, 1] / z[front] + K[1, 2]
    e = np.c_[u, v] - x_px
    inl = front & (np.linalg.norm(np.nan_to_num(e, nan=np.inf), axis=1) < inlier_px)
    n = int(inl.sum())
    if n < MIN_POINTS:
        return None
    p, zi = p_c[inl], z[inl]
    d_proj = np.zeros((n, 2, 3))                      # d(u, v) / d p_c
    d_proj[:, 0, 0], d_proj[:, 0, 2] = fx / zi, -fx * p[:, 0] / zi ** 2
    d_proj[:, 1, 1], d_proj[:, 1, 2] = fy / zi, -fy * p[:, 1] / zi ** 2
    J = np.empty((n, 2, 6))
    J[:, :, 3:] = d_proj                                  # d p_c / d dt = I
    zero = np.zeros(n)
    minus_skew = np.stack([np.stack([zero, p[:, 2], -p[:, 1]], 1), np.stack([-p[:, 2], zero, p[:, 0]], 1),
                           np.stack([p[:, 1], -p[:, 0], zero], 1)], 1)      # -[p_c]x: d p_c / d dphi
    J[:, :, :3] = d_proj @ minus_skew
    J = J.reshape(2 * n, 6)
    s2 = float(np.sum(e[inl] ** 2)) / max(2 * n - 6, 1)
    try:
        cov = s2 * np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        return None
    return cov[:3, :3] if np.all(np.isfinite(cov)) else None


def track_pnp_rotation_cov(view, rig, T_kf_c_pnp: np.ndarray, inlier_px: float, max_depth: float,
                           max_triangulation_px: float) -> np.ndarray | None:
    """:func:`pnp_rotation_cov` of the track filter's PnP pose ``T_kf_c_pnp`` from the tracks of ``view``
    (:class:`~vo.rop.tracks.FourView`) triangulated as the filter does (:func:`vo.rop.moving.filter_tracks`)."""
    p_kf, tri = triangulate(rig, view.p1, view.p2, max_depth, max_triangulation_px)
    if tri.sum() < MIN_POINTS:
        return None
    cam = rig.cameras[0]
    return pnp_rotation_cov(p_kf[tri], undistort_px(view.p3[tri], cam), np.asarray(cam.K, float), T_kf_c_pnp,
                            inlier_px)


def rotation_test(R_rop: np.ndarray, cov_rop_left: np.ndarray, R_pnp: np.ndarray, cov_pnp_right: np.ndarray,
                  prob: float) -> RotationTest:
    """The test of the module docstring: ``R_rop``, ``R_pnp`` (3,3) two estimates of ``R_kf_c``;
    ``cov_rop_left`` (3,3) the ROP adjustment's (left perturbation), ``cov_pnp_right`` (3,3) the PnP fit's
    (right perturbation), rad^2."""
    R_rop = np.asarray(R_rop, float)
    r = so3_log(R_rop.T @ np.asarray(R_pnp, float))
    C = R_rop.T @ np.asarray(cov_rop_left, float) @ R_rop + np.asarray(cov_pnp_right, float)
    try:
        d2 = float(r @ np.linalg.solve(C, r))
    except np.linalg.LinAlgError:
        d2 = float("inf")
    return RotationTest(d2 if np.isfinite(d2) else float("inf"), chi2_threshold(prob),
                        float(np.degrees(np.linalg.norm(r))))



class RotationTester:
    """The test of the module docstring along one run, with the variance factor of the disagreement estimated from
    the run's own steps: ``d2 / s2`` against ``chi2_3(prob)``, ``s2 = max(1, median(d2 of the previous steps) /
    median(chi2_3))`` once :data:`MIN_FACTOR_STEPS` steps were tested (before that no step is failed).

    The first-order covariances count image noise only; calibration, lens and tracker errors are common to every
    step of a recording and scale the disagreement by a factor of its own (measured, ``d2`` median: 4.5 on the
    indoor route, 62 on the real KITTI turn, against 2.37 for a true chi-square). As seed 000's a-posteriori
    variance of unit weight ``sigma0^2 = v^T W v / r`` rescales its adjustment's covariance by the residuals, the
    factor ``s2`` rescales the test by the run's disagreements; the median keeps the steps the test is for (a
    minority) from setting it, and the floor at 1 never lets the covariances grow optimistic. ``inlier_px``,
    ``max_depth``, ``max_triangulation_px`` as the track filter's (:func:`vo.rop.moving.filter_tracks`)."""

    def __init__(self, prob: float, inlier_px: float, max_depth: float, max_triangulation_px: float):
        self.prob, self.inlier_px = float(prob), float(inlier_px)
        self.max_depth, self.max_triangulation_px = float(max_depth), float(max_triangulation_px)
        self.d2: list[float] = []

    def variance_factor(self) -> float | None:
        """``s2`` (class docstring), None before :data:`MIN_FACTOR_STEPS` tested steps."""
        if len(self.d2) < MIN_FACTOR_STEPS:
            return None
        return max(1.0, float(np.median(self.d2)) / CHI2_MEDIAN)

    def miss(self, T_kf_c: np.ndarray, cov_step: np.ndarray, T_pnp: np.ndarray | None, view, rig) -> str:
        """Why the ROP step ``T_kf_c`` (4,4; ``cov_step`` (6,6) its adjustment covariance, rotation first) is
        suspect in rotation ("" when it is not) against the track filter's PnP pose ``T_pnp`` of the tracks of
        ``view`` (:class:`~vo.rop.tracks.FourView`). No check without a PnP pose or its covariance."""
        if T_pnp is None or view is None:
            return ""
        cov_pnp = track_pnp_rotation_cov(view, rig, T_pnp, self.inlier_px, self.max_depth, self.max_triangulation_px)
        if cov_pnp is None:
            return ""
        t = rotation_test(np.asarray(T_kf_c)[:3, :3], np.asarray(cov_step)[:3, :3], T_pnp[:3, :3], cov_pnp,
                          self.prob)
        s2 = self.variance_factor()
        self.d2.append(t.d2)
        if s2 is None or t.d2 / s2 <= t.threshold:
            return ""
        return (f"ROP rotation {t.angle_deg:.2f} deg from the track filter's PnP pose: Mahalanobis d2 {t.d2:.1f} / "
                f"variance factor {s2:.2f} > chi2_3({self.prob}) {t.threshold:.2f}")


def readjusted_step(ropset, result, R_kf_c: np.ndarray, config: AdjustmentConfig,
                    t_direction: np.ndarray | None = None) -> np.ndarray | None:
    """``T_kf_c`` (4,4) with the rotation ``R_kf_c`` (3,3; the PnP fit's, where the test failed the ROP rotation) and
    the translation of seed 000's step 2 (eqs. 2-3, :func:`vo.rop.adjustment.adjust_translations`) re-solved with that
    rotation as its fixed coefficient, from the ROPs ``ropset`` and the adjustment ``result``'s positions; with
    ``t_direction`` (3,) (the PnP translation) only the re-solved length is kept and the direction is that one's.
    The PnP length is not taken: a calibration scale error moves it (8-16 % on the real KITTI turn), not the ROPs'
    scale, which rests on the calibrated baseline alone; the ROPs' direction is not kept where their rotation failed:
    five-point geometry confuses the two (close, nearly planar walls). None when the re-solve diverges."""
    R = np.asarray(R_kf_c, float)
    tra = adjust_translations(ropset, R, result.T_c1_c3[:3, 3], result.T_c1_c4[:3, 3], config)
    if not np.all(np.isfinite(tra.x)):
        return None
    t = tra.x[:3]
    if t_direction is not None and np.linalg.norm(t_direction) > 0:
        t = np.linalg.norm(t) * np.asarray(t_direction, float) / np.linalg.norm(t_direction)
    return make_T(R, t)
