"""Distance-consistency outlier test, seed 001 eq. 2 and its weight-count rule.

A rigid motion between the sites keeps distances: for tie points a, b intersected at both sites
(``P1`` in the previous site's body frame, ``P2`` in the current one), ``e = | |P1_a - P1_b| -
|P2_a - P2_b| |`` should be zero. A pair passes when ``e <= e_L``; each point starts with weight 0
and both points of a passing pair gain 1; a point whose final weight is below the weight threshold is
an outlier. Thresholds are options: ``e_L(a, b) = abs_m + k_sigma * sqrt(sum of the four points'
range variances)`` with the stereo range error of eq. 7, ``sigma_r = r^2 sigma_p / (f B)`` (a fixed
``e_L`` would be too strict far away and too loose near), and the weight threshold
``fraction * (n - 1)`` (a point must agree with that share of the others).
"""
from __future__ import annotations

import numpy as np

from vo.errors import VoError


def range_sigma(P_c: np.ndarray, f: float, baseline: float, sigma_p: float) -> np.ndarray:
    """Eq. 7: (N,) range standard deviation ``r^2 sigma_p / (f B)`` of points ``P_c`` (N,3)."""
    r = np.linalg.norm(P_c, axis=1)
    return r * r * sigma_p / (f * baseline)


def consistency_weights(P1: np.ndarray, P2: np.ndarray, e_L: np.ndarray) -> np.ndarray:
    """(N,) weights: number of partners b with ``|L1_ab - L2_ab| <= e_L[a, b]`` (eq. 2)."""
    P1, P2 = np.asarray(P1, float), np.asarray(P2, float)
    if P1.shape != P2.shape or P1.ndim != 2 or P1.shape[1] != 3:
        raise VoError(f"consistency: expected two (N,3) point sets, got {P1.shape} and {P2.shape}")
    L1 = np.linalg.norm(P1[:, None] - P1[None], axis=2)
    L2 = np.linalg.norm(P2[:, None] - P2[None], axis=2)
    passed = np.abs(L1 - L2) <= e_L
    np.fill_diagonal(passed, False)
    return passed.sum(axis=1)


def distance_consistency(P1: np.ndarray, P2: np.ndarray, sigma1: np.ndarray, sigma2: np.ndarray,
                         abs_m: float, k_sigma: float, weight_fraction: float, iterations: int = 1) -> tuple:
    """-> (inlier mask (N,), weights (N,)). ``sigma1``/``sigma2`` (N,) range sigmas at each site.
    With ``iterations`` > 1 the test is repeated on the survivors (weights among them only), which
    matters when outliers are many: the paper's single pass keeps a point that agrees with half of a
    set that is itself mostly wrong."""
    n = len(P1)
    keep = np.ones(n, bool)
    w = np.zeros(n, int)
    var = np.asarray(sigma1, float) ** 2 + np.asarray(sigma2, float) ** 2
    for _ in range(max(1, int(iterations))):
        idx = np.flatnonzero(keep)
        if idx.size < 2:
            return np.zeros(n, bool), w
        e_L = abs_m + k_sigma * np.sqrt(var[idx, None] + var[None, idx])
        w = np.zeros(n, int)
        w[idx] = consistency_weights(P1[idx], P2[idx], e_L)
        new = keep & (w >= weight_fraction * (idx.size - 1))
        if np.array_equal(new, keep):
            break
        keep = new
    return keep, w
