"""Per-frame pose covariance of the VINS output (``FrameResult.cov``) and the window's pose marginal.

gtsam's marginal covariance of ``X(k)`` = ``T_w_i`` is in its tangent space ``[dtheta, dt]`` with the
perturbation on the right: ``T_w_i = T_hat Exp([dtheta, dt])``, i.e. ``R = R_hat Exp(dtheta)`` and
``p = p_hat + R_hat dt`` to first order. The output pose is ``T_o_c = T_o_w T_w_i T_i_c`` (``T_o_w``, ``T_i_c``
fixed), and ``FrameResult.cov`` is that of ``[rotation vector, position]`` of ``T_o_c`` with the rotation
perturbed on the left (``R = Exp(dphi) R_hat``). To first order:

    dphi_o = R_o_w R_w_i dtheta
    dp_o   = R_o_w (R_w_i dt - [R_w_i p_i_c]x R_w_i dtheta)

so ``cov = J P J^T`` with ``J = [[A, 0], [-R_o_w [R_w_i p_i_c]x R_w_i, A]]``, ``A = R_o_w R_w_i``.
The covariance is relative to the window's gauge (the prior on the first window state and the
marginalisation priors); the uncertainty of ``T_o_w`` itself (fixed at initialisation) is not included.
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import skew

# reported while the estimator is initialising (identity pose, motion unknown): 1 rad and 100 m std
INIT_COV = np.diag([1.0] * 3 + [1e4] * 3)


def output_jacobian(T_o_w: np.ndarray, T_w_i: np.ndarray, T_i_c: np.ndarray) -> np.ndarray:
    """6x6 Jacobian of ``[dphi_o (left), dp_o]`` of ``T_o_c`` w.r.t. gtsam's ``[dtheta, dt]`` of ``T_w_i``."""
    R_o_w, R_w_i = T_o_w[:3, :3], T_w_i[:3, :3]
    A = R_o_w @ R_w_i
    J = np.zeros((6, 6))
    J[:3, :3] = A
    J[3:, :3] = -R_o_w @ skew(R_w_i @ T_i_c[:3, 3]) @ R_w_i
    J[3:, 3:] = A
    return J


def output_covariance(P_x: np.ndarray, T_o_w: np.ndarray, T_w_i: np.ndarray, T_i_c: np.ndarray) -> np.ndarray:
    """``FrameResult.cov`` from gtsam's marginal ``P_x`` (6x6) of ``X(k)``; symmetrised."""
    J = output_jacobian(T_o_w, T_w_i, T_i_c)
    C = J @ np.asarray(P_x, float) @ J.T
    return 0.5 * (C + C.T)


def pose_block_marginal(H: np.ndarray, n_s: int, d: int = 3) -> np.ndarray:
    """Covariance of the first 6 variables of information ``H`` whose variables after ``n_s`` are d-vectors
    coupled only to the first ``n_s`` (landmarks): Schur complement of the dxd landmark blocks, then a solve."""
    m = (H.shape[0] - n_s) // d
    H_ss, H_sl = H[:n_s, :n_s], H[:n_s, n_s:].reshape(n_s, m, d)
    blocks = np.stack([H[n_s + d * j:n_s + d * j + d, n_s + d * j:n_s + d * j + d] for j in range(m)]) if m else \
        np.zeros((0, d, d))
    Y = np.einsum("iak,akl->ial", H_sl, np.linalg.inv(blocks), optimize=True)
    S = H_ss - Y.reshape(n_s, -1) @ H_sl.reshape(n_s, -1).T
    P = np.linalg.solve(S, np.eye(n_s)[:, :6])[:6]
    return 0.5 * (P + P.T)
