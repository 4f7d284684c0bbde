"""Joint covariance of the four ROPs of one epoch from the pixel noise of their shared tracks (extension).

Seed 000 gives no precision model, and :mod:`vo.rop.propagation` by default treats the four ROPs as
independent. With the KLT four-view front-end they are not: every track gives ``x1`` to ROPs 13 and
14, ``x2`` to 23 and 24, ``x3`` to 13 and 23, ``x4`` to 14 and 24. Here each ROP's Sampson-LM
solution ``z = [rotvec, direction tangent]`` (OpenCV convention, :func:`vo.rop.relative.refine_essential`)
is differentiated with respect to the normalized image coordinates of its inlier matches by the
implicit-function theorem at the optimum (``grad = J^T r = 0``):

    ``dz / dx_n = -(J^T J)^-1 J_n^T dr_n/dx_n``     (Gauss-Newton Hessian; the dropped terms are O(r))

``dr_n / dx_n`` (1,4) by central differences of the vectorised Sampson distance (the residual of
match n depends only on match n's four coordinates). :func:`vo.rop.relative.project_jacobian` maps
``dz`` to ``[dphi, d rhat_i_j]``. All four ROPs are written against ONE vector of track coordinates
(track k, image m, axis c at ``8k + 2(m-1) + c``), so ``F_p = sigma dtheta_p/dx`` (6, 8N) are factors
of the joint covariance: ``Sigma_pq = F_p F_q^T`` (cross-covariances included). ``sigma`` is one
isotropic noise per coordinate for all four images (normalized units), pooled from the Sampson
residuals of the epoch: the Sampson distance is the first-order geometric error over both images,
so for per-coordinate noise ``sigma`` its variance is ``sigma^2`` (not ``2 sigma^2``); with 5
parameters fitted per ROP, ``sigma^2 = sum r^2 / sum (n_p - 5)``.
Assumptions: equal, independent noise on all track coordinates (KLT noise of x3 accumulated over
frame-to-frame tracking is not modelled separately); inlier sets fixed (RANSAC decisions and the
estimator's gates are not differentiated).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from rigs.geometry import skew
from vo.rop.relative import project_jacobian, sampson_jacobian, sampson_residuals, tangent_basis

FD_STEP = 1e-6     # normalized coordinates (~1e-3 px at f = 500): central-difference error ~h^2


def opencv_pose(R_i_j: np.ndarray, rhat_i_j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Project convention ``(R_i_j, rhat_i_j)`` -> OpenCV ``(R, t)`` (``x_j = R x_i + t``, unit t)."""
    R = np.asarray(R_i_j, float).T
    return R, -R @ np.asarray(rhat_i_j, float)


def residual_point_jacobian(E: np.ndarray, x_i: np.ndarray, x_j: np.ndarray) -> np.ndarray:
    """(N,4) ``d r_n / d [x_i, y_i, x_j, y_j]_n`` of the Sampson distances (central differences)."""
    out = np.zeros((len(x_i), 4))
    for c in range(4):
        d = np.zeros((len(x_i), 2))
        d[:, c % 2] = FD_STEP
        if c < 2:
            rp, rm = sampson_residuals(E, x_i + d, x_j), sampson_residuals(E, x_i - d, x_j)
        else:
            rp, rm = sampson_residuals(E, x_i, x_j + d), sampson_residuals(E, x_i, x_j - d)
        out[:, c] = (rp - rm) / (2 * FD_STEP)
    return out


def rop_point_sensitivity(R_i_j, rhat_i_j, x_i: np.ndarray, x_j: np.ndarray) -> np.ndarray:
    """(6, N, 4) ``d [dphi, d rhat_i_j] / d [x_i, x_j]_n`` of the Sampson-LM ROP at its optimum
    (``x_i``, ``x_j`` the inlier matches it was fitted to, normalized coordinates)."""
    R, t = opencv_pose(R_i_j, rhat_i_j)
    B = tangent_basis(t)
    _, J = sampson_jacobian(R, t, B, x_i, x_j)                      # (N,5)
    D = residual_point_jacobian(skew(t) @ R, x_i, x_j)              # (N,4)
    dz = -np.einsum("ab,nb,nc->anc", np.linalg.pinv(J.T @ J), J, D)  # (5,N,4)
    return np.einsum("ka,anc->knc", project_jacobian(R, t), dz)


def pair_track_index(pair: str, ok4: np.ndarray) -> np.ndarray:
    """Track indices of the matches of ``pair`` as :meth:`vo.rop.tracks.FourView.pair` orders them."""
    return np.flatnonzero(ok4) if pair[1] == "4" else np.arange(len(ok4))


def pooled_sigma(rops: dict, x_pairs: dict) -> float:
    """One per-coordinate noise sigma (normalized units) from the Sampson residuals of all ok ROPs."""
    ss, dof = 0.0, 0
    for p, m in rops.items():
        x_i, x_j = x_pairs[p]
        R, t = opencv_pose(m.R_i_j, m.rhat_i_j)
        r = sampson_residuals(skew(t) @ R, x_i[m.inlier_mask], x_j[m.inlier_mask])
        ss, dof = ss + float(r @ r), dof + max(len(r) - 5, 0)
    return float(np.sqrt(ss / max(dof, 1)))


def pixel_factors(rops: dict, x_pairs: dict, ok4: np.ndarray, sigma=None) -> dict:
    """pair -> (6, 8N) factor ``F_p`` of the joint ROP covariance over N four-view tracks.

    ``rops`` pair -> ok :class:`~vo.rop.relative.RopMeasurement`; ``x_pairs`` pair -> its normalized
    matches ``(x_i, x_j)`` (as given to the ROP solver); ``ok4`` (N,) the tracks with an image-4 point.
    ``sigma``: per-coordinate noise (normalized units) or None (pooled from the residuals)."""
    s = pooled_sigma(rops, x_pairs) if sigma is None else float(sigma)
    n = len(ok4)
    out = {}
    for p, m in rops.items():
        x_i, x_j = x_pairs[p]
        inl = m.inlier_mask
        S = rop_point_sensitivity(m.R_i_j, m.rhat_i_j, x_i[inl], x_j[inl])      # (6, n_inl, 4)
        tracks = pair_track_index(p, ok4)[inl]
        F = np.zeros((6, n, 4, 2))
        F[:, tracks, int(p[0]) - 1] = S[:, :, :2]
        F[:, tracks, int(p[1]) - 1] = S[:, :, 2:]
        out[p] = s * F.reshape(6, 8 * n)
    return out


def with_pixel_factors(ropset, x_pairs: dict, ok4: np.ndarray, sigma=None):
    """``ropset`` with ``px_factor`` set on its ok ROPs (poses and weights unchanged)."""
    ok = {p: ropset.rops[p] for p in ropset.ok_pairs}
    if not ok:
        return ropset
    F = pixel_factors(ok, x_pairs, ok4, sigma)
    rops = {p: (dataclasses.replace(m, px_factor=F[p]) if p in F else m) for p, m in ropset.rops.items()}
    return dataclasses.replace(ropset, rops=rops)


def joint_rop_cov(rops, pairs: tuple):
    """(6n, 6n) covariance of ``[dphi, d rhat]`` of ``pairs`` with cross-covariances from their
    ``px_factor``; None unless every pair has one (then :mod:`vo.rop.propagation` uses ``cov6``)."""
    F = [getattr(rops.rops[p], "px_factor", None) for p in pairs]
    if any(f is None for f in F) or len({f.shape[1] for f in F}) != 1:
        return None
    Fs = np.vstack(F)
    C = Fs @ Fs.T
    return 0.5 * (C + C.T)
