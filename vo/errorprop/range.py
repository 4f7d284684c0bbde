"""Stereo range error and planar position covariance (seed 001, eq. 6-8).

For the normal-case stereo pair the depth is ``Y = B f / p`` (eq. 6), so a parallax error
``sigma_p`` gives the range error (eq. 7)::

    sigma_r = r^2 sigma_p / (b f)

With range ``r`` and azimuth ``theta`` (x = r cos theta, y = r sin theta) the planar covariance
is ``J diag(sigma_r^2, sigma_theta^2) J^T`` with ``J = [[cos, -r sin], [sin, r cos]]`` (eq. 8).

Typo in the printed eq. 8: its off-diagonal reads ``sin cos sigma_r^2 - r^2 (sin cos)^2 sigma_theta^2``;
first-order propagation gives ``sin cos (sigma_r^2 - r^2 sigma_theta^2)`` (the product is not
squared - the squared form is not even dimensionally consistent with the diagonal terms'
structure and makes the matrix non-positive-definite for some angles). We implement the derivation.
"""
from __future__ import annotations

import numpy as np


def range_sigma(r, baseline_m: float, f_px: float, sigma_p_px: float) -> np.ndarray:
    """Eq. 7: 1-sigma range error (m) at range(s) ``r`` (m), any shape."""
    r = np.asarray(r, dtype=float)
    return r ** 2 * sigma_p_px / (baseline_m * f_px)


def azimuth_sigma_from_pixels(pixels: float, f_px: float) -> float:
    """Seed 001's azimuth error model: ``sigma_theta = atan(pixels / f)`` (rad)."""
    return float(np.arctan(pixels / f_px))


def planar_covariance(r: float, theta: float, sigma_r: float, sigma_theta: float) -> np.ndarray:
    """Eq. 8 (corrected): (2,2) covariance of (x, y) = r (cos theta, sin theta)."""
    c, s = np.cos(theta), np.sin(theta)
    J = np.array([[c, -r * s], [s, r * c]])
    return J @ np.diag([sigma_r ** 2, sigma_theta ** 2]) @ J.T
