"""Robust losses of the visual residuals, vectorized over observations.

``weight`` and ``loss`` are those of gtsam's ``noiseModel.mEstimator`` (``Cauchy``, ``Huber``; "none" is the
Gaussian) on the whitened residual norm ``e`` (k,), with per-observation thresholds ``c`` (k,);
``tests/test_vins_robust.py`` checks them against gtsam's own. They let one factor carry many observations
with the robust weighting that gtsam's ``noiseModel.Robust`` would give each of them on its own
(:mod:`vo.vins.inverse_depth`).
"""
from __future__ import annotations

import numpy as np

KINDS = ("none", "huber", "cauchy")


def weight(kind: str, c: np.ndarray, e: np.ndarray) -> np.ndarray:
    """IRLS weight w(e) (k,): 1 / (1 + e^2/c^2) (Cauchy), min(1, c/e) (Huber), 1 (none)."""
    e = np.abs(e)
    if kind == "cauchy":
        return 1.0 / (1.0 + (e / c) ** 2)
    if kind == "huber":
        return np.minimum(1.0, c / np.maximum(e, 1e-300))
    return np.ones_like(e)


def loss(kind: str, c: np.ndarray, e: np.ndarray) -> np.ndarray:
    """rho(e) (k,): c^2/2 log(1 + e^2/c^2) (Cauchy), e^2/2 inside c and c e - c^2/2 outside (Huber), e^2/2."""
    e = np.abs(e)
    if kind == "cauchy":
        return 0.5 * c * c * np.log1p((e / c) ** 2)
    if kind == "huber":
        return np.where(e <= c, 0.5 * e * e, c * e - 0.5 * c * c)
    return 0.5 * e * e
