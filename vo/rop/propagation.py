"""First-order propagation of the ROPs' own covariances through the two-step adjustment (extension).

Seed 000 gives no precision model. Each ROP's Sampson fit gives the (6,6) covariance ``cov6`` of
``[dphi, d rhat_i_j]`` (:func:`vo.rop.relative.project_cov`); the adjustment is a weighted LS
estimator ``x = K z`` at convergence, whatever its weights (inlier counts or inverse variances), so

    ``cov_x = L diag(cov6_p) L^T``  (the "sandwich" ``(A^T W A)^-1 A^T W S W A (A^T W A)^-1``),

with ``L`` chaining: rotation elements ``vec(dR_i_j) = M_p dphi_p`` -> step-1 gain ``K1`` -> rotation
vectors (``G``); directions ``d rhat_p`` -> step-2 gain ``K2``; and step 1 -> step 2 through
``d r / d phi3`` (``R_1_3`` is a coefficient of the calibrated ``rhat_3_4``). This is the a-priori
covariance of the *chosen* estimator, so it stays valid with the paper's inlier weights.
Approximations: the ROPs are treated as independent (``S = diag(cov6_p)``), but the KLT front-end
gives all four the same tracks (13 and 24 share image 3's and 4's points), so their errors are
positively correlated (a joint model of that correlation was measured to matter little for the
end-point spread: docs/studies/rop_consistency.md); the Sampson covariance assumes independent,
equal image noise on the inliers.
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import skew


def rotation_element_map(R: np.ndarray) -> np.ndarray:
    """(9,3) ``d vec(R) / d dphi`` for ``R = exp(dphi) R_hat`` (row-major vec)."""
    return np.stack([(skew(e) @ R).ravel() for e in np.eye(3)], axis=1)


def propagated_cov(rops, pairs: tuple, gain_rot: np.ndarray, gain_dir: np.ndarray, dx_dphi3: np.ndarray):
    """(12,12) covariance of ``[phi3, phi4, r3, r4]``.

    ``pairs``: the soft pairs in row order; ``gain_rot`` (6, 9n) maps their rotation-element errors
    to ``[phi3, phi4]``; ``gain_dir`` (6, 3n) maps direction errors to ``[r3, r4]``; ``dx_dphi3``
    (6,3). ``S`` block-diagonal ``cov6``. Returns None unless every pair has one."""
    if any(getattr(rops.rops[p], "cov6", None) is None for p in pairs):
        return None
    n = len(pairs)
    L = np.zeros((12, 6 * n))
    S = np.zeros((6 * n, 6 * n))
    for k, p in enumerate(pairs):
        m = rops.rops[p]
        Lphi = gain_rot[:, 9 * k:9 * k + 9] @ rotation_element_map(m.R_i_j)     # (6,3)
        L[:6, 6 * k:6 * k + 3] = Lphi
        L[6:, 6 * k:6 * k + 3] = dx_dphi3 @ Lphi[:3]
        L[6:, 6 * k + 3:6 * k + 6] = gain_dir[:, 3 * k:3 * k + 3]
        S[6 * k:6 * k + 6, 6 * k:6 * k + 6] = m.cov6
    C = L @ S @ L.T
    return 0.5 * (C + C.T)
