"""Seed 002 §4: adaptive covariance (eq. 22-27) and the adaptive Huber M-estimator (eq. 28-30).

* eq. 22-25: ``H`` stacks the line-of-sight unit vectors from the camera to the m features of the image
  (``(x_i - x) / lambda_i`` with ``lambda_i`` the range), ``Q = (H^T H)^-1``, ``g_f = sqrt(trace Q)`` (a PDOP).
* eq. 26-27: ``Sigma = P * N * (1/g_f) * s`` with ``P = F_c/1.5 * I``. ``P`` is VINS-Mono's square-root
  information (``sqrt_info = FOCAL_LENGTH / 1.5``), so the weight ``w = N s / g_f`` multiplies the
  square-root information: the residual standard deviation (normalized coordinates) is ``1.5 / (F_c w)``.
  The paper calls Sigma an "information matrix" without saying whether P is the square root; we follow the
  code the paper builds on. Options switch the g_f and N parts off (seed 002's four configurations).
* N (eq. 21, 26, 30): "the number of times that feature l is tracked", counted since its first detection, not
  capped and not limited to the window; §4.1: "the more times we see the same feature, the better is the
  feature quality", so N *raises* the information (eq. 26) and the Huber threshold (eq. 30).
* eq. 30: ``k_t = M_s * N``. The paper's Huber (eq. 28-29) acts on the residual; as in VINS-Mono (Ceres)
  and gtsam's ``noiseModel.Robust`` it is applied to the whitened residual norm.
"""
from __future__ import annotations

import gtsam
import numpy as np


def geometry_factor(p_w_features: np.ndarray, p_w_cam: np.ndarray) -> float:
    """g_f (eq. 22-25) of features (m,3) seen from ``p_w_cam``; ``nan`` when H^T H is singular or m < 3."""
    d = np.asarray(p_w_features, float) - np.asarray(p_w_cam, float)
    r = np.linalg.norm(d, axis=1)
    d = d[r > 1e-9] / r[r > 1e-9, None]
    if len(d) < 3:
        return float("nan")
    HtH = d.T @ d
    if np.linalg.cond(HtH) > 1e12:
        return float("nan")
    return float(np.sqrt(np.trace(np.linalg.inv(HtH))))


def visual_weight(config, g_f: float, count: int) -> float:
    """w of eq. 26 (1 for the fixed information of eq. 27); a nan g_f counts as 1 (no geometry yet)."""
    w = 1.0
    if config.use_gf and np.isfinite(g_f) and g_f > 0:
        w /= g_f
    if config.use_track_count:
        w *= count * config.s
    return float(min(max(w, config.weight_min), config.weight_max))


def huber_k(config, count: int) -> float | None:
    """Huber threshold (whitened units): fixed ``robust_k``, ``M_s * N`` (eq. 30), or None (no Huber)."""
    if config.robust == "huber":
        return config.robust_k
    if config.robust == "adaptive-huber":
        return config.m_s * count
    return None


def residual_sigma(config, g_f: float, count: int, fx: float) -> float:
    """Standard deviation of one reprojection residual in pixels of focal length ``fx`` (radians at fx = 1)."""
    return config.pixel_sigma / config.virtual_focal * fx / visual_weight(config, g_f, count)


def robust_kernel(config, count: int) -> tuple[str, float]:
    """(kind, threshold) of the robust loss (:data:`vo.vins.robust.KINDS`): Cauchy of scale ``robust_k``, Huber
    of :func:`huber_k`, or ("none", inf)."""
    if config.robust == "cauchy":
        return "cauchy", config.robust_k
    k = huber_k(config, count)
    return ("none", float("inf")) if k is None else ("huber", k)


def noise_model(config, g_f: float, count: int, fx: float):
    """gtsam noise model of one reprojection residual in pixels of focal length ``fx``."""
    base = gtsam.noiseModel.Isotropic.Sigma(2, residual_sigma(config, g_f, count, fx))
    kind, c = robust_kernel(config, count)
    make = {"cauchy": gtsam.noiseModel.mEstimator.Cauchy.Create, "huber": gtsam.noiseModel.mEstimator.Huber.Create}
    return base if kind == "none" else gtsam.noiseModel.Robust.Create(make[kind](c), base)
