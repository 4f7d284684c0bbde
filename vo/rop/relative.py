"""One ROP (relative orientation of image j in image i's frame) from point correspondences.

OpenCV's ``recoverPose`` / ``decomposeEssentialMat`` give ``R, t`` with ``x_j = R x_i + t`` (points of camera i into
camera j), i.e. ``R = R_cj_ci`` and ``t = t_cj_ci``. :func:`rop_from_opencv` converts that, in one
place, to the seed-000 / project convention ``R_i_j = R^T`` and ``rhat_i_j = -R^T t / |t|``
(direction from the origin of C_i to the origin of C_j, expressed in C_i).

Per-ROP precision (our extension; seed 000 only weights by inlier count): the final Sampson
Gauss-Newton gives the 5x5 covariance ``s^2 (J^T J)^-1`` of ``[rotvec (3), direction tangent (2)]``
with ``s^2 = sum(r^2) / (n - 5)`` the Sampson residual variance of the inliers (normalised units).
``sigma_rot_rad`` = RMS per-axis rotation sigma, ``sigma_dir_rad`` = RMS per-tangent-axis direction
sigma (both rad); the estimator turns them into the a-priori unit-weight sigmas of the adjustment.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import cv2
import numpy as np

from vo.errors import VoError
from rigs.geometry import skew
from rigs.geometry.pinhole import undistort_points

MIN_INLIERS = 8
LOSSES = ("gate", "cauchy", "tukey")   # final fit: hard inlier gate + least squares, or a robust loss (estimate_rop_normalized)
ROBUST_SCALE = {"cauchy": 1.0, "tukey": 2.0}   # loss scale in units of the inlier threshold


@dataclass(frozen=True)
class RopMeasurement:
    """``R_i_j`` (3,3), ``rhat_i_j`` (3,) unit, ``n_inliers``, ``inlier_mask`` (N,) bool, ``ok``;
    ``sigma_rot_rad`` / ``sigma_dir_rad`` per-axis sigmas from the Sampson fit (None if unknown)."""

    R_i_j: np.ndarray
    rhat_i_j: np.ndarray
    n_inliers: int
    inlier_mask: np.ndarray
    ok: bool
    message: str = ""
    sigma_rot_rad: Optional[float] = None
    sigma_dir_rad: Optional[float] = None
    rms_px: Optional[float] = None
    cov6: Optional[np.ndarray] = None      # (6,6) of [dphi (R_i_j = exp(dphi) R_hat), d rhat_i_j]


def _spread(x: np.ndarray) -> float:
    """RMS distance of points (N,2) from their centroid (0 for fewer than 2 points)."""
    return float(np.sqrt(np.mean(np.sum((x - x.mean(axis=0)) ** 2, axis=1)))) if len(x) > 1 else 0.0


def failed_rop(n_points: int, message: str) -> RopMeasurement:
    """A not-ok measurement (identity, +z direction, no inliers); never NaN."""
    return RopMeasurement(np.eye(3), np.array([0.0, 0.0, 1.0]), 0,
                          np.zeros(n_points, dtype=bool), False, message)


def rop_from_opencv(R_cj_ci: np.ndarray, t_cj_ci: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV's ``(R, t)`` (``x_j = R x_i + t``) -> ``(R_i_j (3,3), rhat_i_j (3,))``."""
    R_i_j = np.asarray(R_cj_ci, dtype=float).T
    t_i_j = -R_i_j @ np.asarray(t_cj_ci, dtype=float).reshape(3)
    return R_i_j, t_i_j / np.linalg.norm(t_i_j)


def normalized_points(p_px: np.ndarray, K: np.ndarray, dist) -> np.ndarray:
    """(N,2) distorted pixels -> (N,2) undistorted normalized image coordinates ``(x/z, y/z)``
    (:func:`rigs.geometry.pinhole.undistort_points`: 30 iterations, 1e-12)."""
    return undistort_points(p_px, K, dist, iters=30, eps=1e-12)


def _homog(x: np.ndarray) -> np.ndarray:
    """(N,2) -> (N,3) ``[x, 1]`` (the values of ``np.c_[x, ones]``, without its indexing machinery)."""
    h = np.empty((len(x), 3))
    h[:, :2] = x
    h[:, 2] = 1.0
    return h


_SKEW_E = skew(np.eye(3))      # (3,3,3) cross-product matrices of the unit axes


def sampson_residuals(E: np.ndarray, x_i: np.ndarray, x_j: np.ndarray) -> np.ndarray:
    """Signed Sampson distances (N,) of normalized matches to ``x_j^T E x_i = 0``; ``E`` may be
    (K,3,3), then the result is (K,N)."""
    h_i, h_j = _homog(x_i), _homog(x_j)
    Ex_i = np.einsum("...ab,nb->...na", E, h_i)
    Etx_j = np.einsum("...ba,nb->...na", E, h_j)
    den = Ex_i[..., 0] ** 2 + Ex_i[..., 1] ** 2 + Etx_j[..., 0] ** 2 + Etx_j[..., 1] ** 2
    return np.einsum("nj,...nj->...n", h_j, Ex_i) / np.sqrt(np.maximum(den, 1e-300))


def project_jacobian(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(6,5) ``d [dphi, d rhat_i_j] / d [rotvec of R, tangent of t]`` (see :func:`project_cov`)."""
    t = t.ravel() / np.linalg.norm(t)
    B = tangent_basis(t)
    J = np.zeros((6, 5))
    J[:3, :3] = -R.T
    J[3:, :3] = -R.T @ skew(t)
    J[3:, 3:] = -R.T @ B
    return J


def project_cov(R: np.ndarray, t: np.ndarray, cov5: np.ndarray) -> np.ndarray:
    """Sampson ``cov5`` of OpenCV's ``(R, t)`` (``[rotvec of R, tangent of t]``, basis as in
    :func:`refine_essential`) -> (6,6) covariance of ``[dphi, d rhat_i_j]`` in the project convention:
    ``R_i_j = R^T`` so ``dphi_ij = -R^T dphi``; ``rhat_i_j = -R^T t`` so
    ``d rhat = -R^T skew(t) dphi - R^T B dalpha`` (from ``d(R^T) = -R^T skew(dphi)``)."""
    J = project_jacobian(R, t)
    C = J @ cov5 @ J.T
    return 0.5 * (C + C.T)


def _rodrigues(phi: np.ndarray) -> np.ndarray:
    """(3,) rotation vector -> (3,3) (``cv2.Rodrigues``; scipy's is ~20x slower for one vector)."""
    return cv2.Rodrigues(np.asarray(phi, dtype=np.float64).reshape(3, 1))[0]


def _unpack(R, t, B, z):
    tz = t + B @ z[3:]
    return _rodrigues(z[:3]) @ R, tz / np.linalg.norm(tz)


def sampson_jacobian(R, t, B, x_i, x_j) -> tuple[np.ndarray, np.ndarray]:
    """Residuals (N,) and analytic Jacobian (N,5) of the Sampson distances of ``E = [t]x R`` wrt
    ``[dphi (R -> exp(dphi) R), dalpha (t -> t + B dalpha)]``; the distance is invariant to the
    scale of ``E``, so the normalisation of ``t`` drops out. ``r = n / sqrt(d)``,
    ``dr = dn / sqrt(d) - n dd / (2 d^1.5)``."""
    h_i, h_j = _homog(x_i), _homog(x_j)
    r, terms = _sampson_terms(R, t, h_i, h_j)
    return r, _sampson_jac(R, B, h_i, h_j, terms)


def _sampson_terms(R, t, h_i, h_j) -> tuple:
    """Residuals (N,) of :func:`sampson_jacobian` from homogeneous points ``h_i``, ``h_j`` (N,3), and the
    intermediate terms its Jacobian reuses (:func:`_sampson_jac`)."""
    S_t = skew(t)
    E = S_t @ R
    Ex, Etx = h_i @ E.T, h_j @ E                                    # (N,3)
    num = np.sum(h_j * Ex, axis=1)
    den = np.maximum(Ex[:, 0] ** 2 + Ex[:, 1] ** 2 + Etx[:, 0] ** 2 + Etx[:, 1] ** 2, 1e-300)
    sd = np.sqrt(den)
    return num / sd, (S_t, Ex, Etx, num, den, sd)


def _sampson_jac(R, B, h_i, h_j, terms: tuple) -> np.ndarray:
    """(N,5) Jacobian of :func:`sampson_jacobian` from :func:`_sampson_terms`' terms at ``(R, t)``."""
    S_t, Ex, Etx, num, den, sd = terms
    G = np.stack([S_t @ S_e @ R for S_e in _SKEW_E] + [S_b @ R for S_b in skew(B.T)])   # (5,3,3)
    Gx, Gtx = h_i @ G.transpose(0, 2, 1), h_j @ G                  # (5,N,3)
    dnum = np.sum(h_j * Gx, axis=2)
    dden = 2.0 * (Ex[:, 0] * Gx[..., 0] + Ex[:, 1] * Gx[..., 1] + Etx[:, 0] * Gtx[..., 0] + Etx[:, 1] * Gtx[..., 1])
    return (dnum / sd - num * dden / (2.0 * den * sd)).T


def tangent_basis(t: np.ndarray) -> np.ndarray:
    """(3,2) orthonormal basis of the tangent plane of the unit sphere at ``t``."""
    return np.linalg.svd(t.reshape(1, 3))[2][1:].T


def _loss(r: np.ndarray, robust: Optional[tuple]) -> tuple[float, np.ndarray]:
    """``(cost, IRLS weights)`` of the residuals ``r``: least squares ``sum r^2`` (``robust`` None,
    weights 1); ``("cauchy", c)``: ``sum c^2 log(1 + u)``, ``u = (r/c)^2``, weights ``1 / (1 + u)``;
    ``("tukey", c)`` (biweight): ``sum c^2/3 (1 - (1 - u)^3)`` for ``u < 1`` else ``c^2/3``, weights
    ``(1 - u)^2`` inside, 0 outside (costs scaled so that small residuals cost ``r^2``)."""
    if robust is None:
        return float(r @ r), np.ones_like(r)
    kind, c = robust
    u = (r / c) ** 2
    if kind == "cauchy":
        return float(c ** 2 * np.sum(np.log1p(u))), 1.0 / (1.0 + u)
    v = np.clip(1.0 - u, 0.0, None)
    return float(c ** 2 / 3.0 * np.sum(1.0 - v ** 3)), v ** 2


def refine_essential(R: np.ndarray, t: np.ndarray, x_i: np.ndarray, x_j: np.ndarray, iters: int = 8,
                     robust: Optional[tuple] = None):
    """Levenberg-Marquardt on the Sampson distances over ``R`` (rotvec) and unit ``t`` (2 tangent
    params) -> ``(R, t, cov5)``; ``cov5`` (5,5) of ``[rotvec, tangent]`` (``s^2 (J^T J)^-1``).

    OpenCV's RANSAC returns the best minimal-sample model without a final fit to all inliers
    (0.1-0.3 deg errors at 0.3 px noise); this polish recovers ~0.01 deg. Analytic, vectorised
    Jacobian (:func:`sampson_jacobian`); stops when the cost drops by < 1e-6 relative.
    ``robust`` ``(kind, scale)`` (scale in normalised units; None: least squares) minimises that
    robust loss instead, by iteratively reweighted LM (:func:`_loss`); ``cov5`` is then that of the least-squares fit at the
    solution, over all the points given (:func:`sampson_cov`: pass the inliers for a meaningful one).
    ``R, t`` in OpenCV's convention (``x_j = R x_i + t``)."""
    R, t, r, J = _sampson_lm(R, t, x_i, x_j, iters, robust)
    return R, t, _ls_cov5(r, J)


def _sampson_lm(R, t, x_i, x_j, iters: int, robust: Optional[tuple]) -> tuple:
    """:func:`refine_essential`'s LM -> ``(R, t, residuals (N,), Jacobian (N,5))`` at the solution."""
    t = t.ravel() / np.linalg.norm(t)
    lam = 1e-3
    B = tangent_basis(t)
    h_i, h_j = _homog(x_i), _homog(x_j)            # the points' homogeneous form, once for every iteration
    r, terms = _sampson_terms(R, t, h_i, h_j)
    J = _sampson_jac(R, B, h_i, h_j, terms)
    cost, w = _loss(r, robust)
    for _ in range(iters):
        H, g = J.T @ (w[:, None] * J), J.T @ (w * r)
        dz = -np.linalg.solve(H + lam * np.diag(np.diag(H) + 1e-30), g)
        R_n, t_n = _unpack(R, t, B, dz)
        r_n, terms_n = _sampson_terms(R_n, t_n, h_i, h_j)
        c_n, w_n = _loss(r_n, robust)
        if c_n <= cost:                            # the tangent basis and the Jacobian of accepted steps only
            done = cost - c_n <= 1e-6 * cost
            B_n = tangent_basis(t_n)
            J_n = _sampson_jac(R_n, B_n, h_i, h_j, terms_n)
            R, t, B, r, J, cost, w, lam = R_n, t_n, B_n, r_n, J_n, c_n, w_n, lam * 0.1
            if done:
                break
        else:
            lam *= 10.0
            if lam > 1e6:
                break
    return R, t, r, J


def _ls_cov5(r: np.ndarray, J: np.ndarray) -> np.ndarray:
    """``s^2 (J^T J)^-1`` with ``s^2 = sum r^2 / (n - 5)``: residuals (n,), Jacobian (n,5)."""
    return float(r @ r) / max(len(r) - 5, 1) * np.linalg.pinv(J.T @ J)


def sampson_cov(R: np.ndarray, t: np.ndarray, x_i: np.ndarray, x_j: np.ndarray) -> np.ndarray:
    """(5,5) least-squares covariance ``s^2 (J^T J)^-1`` of ``[rotvec, tangent]`` at a fixed ``(R, t)``
    over the matches given, ``s^2 = sum r^2 / (n - 5)`` (as :func:`refine_essential` returns it)."""
    t = t.ravel() / np.linalg.norm(t)
    return _ls_cov5(*sampson_jacobian(R, t, tangent_basis(t), x_i, x_j))


def chirality(R: np.ndarray, t: np.ndarray, x_i: np.ndarray, x_j: np.ndarray) -> np.ndarray:
    """(N,) bool: the two-view midpoint triangulation of each match (``x_j = R x_i + t`` frames)
    has positive depth in both cameras (at any distance; recoverPose's default caps it at 50 |t|)."""
    b = _homog(x_j)
    return _in_front(_homog(x_i) @ R.T, b, np.sum(b * b, 1), t)


def _in_front(a: np.ndarray, b: np.ndarray, bb: np.ndarray, t: np.ndarray) -> np.ndarray:
    """:func:`chirality` from the rays ``a = R h_i``, ``b = h_j`` (N,3) and ``bb = |b|^2`` (N,)."""
    # depths (s_i, s_j) minimising |s_j b - s_i a - t|^2
    aa, ab = np.sum(a * a, 1), np.sum(a * b, 1)
    at, bt = a @ t, b @ t
    det = aa * bb - ab ** 2
    s_i = (ab * bt - bb * at) / np.maximum(det, 1e-300)
    s_j = (aa * bt - ab * at) / np.maximum(det, 1e-300)
    return (s_i > 0) & (s_j > 0) & (det > 1e-300)


def decompose(E: np.ndarray, x_i: np.ndarray, x_j: np.ndarray, mask: np.ndarray):
    """The one of E's four ``(R, t)`` with most masked points in front -> ``(R, t, front (N,))``."""
    R1, R2, t = cv2.decomposeEssentialMat(E)
    h_i, b = _homog(x_i), _homog(x_j)              # shared by the four candidates (:func:`chirality`'s terms)
    bb = np.sum(b * b, 1)
    best = None
    for R in (R1, R2):                             # candidates (R1, t), (R1, -t), (R2, t), (R2, -t)
        a = h_i @ R.T
        for tt in (t, -t):
            front = _in_front(a, b, bb, tt.ravel()) & mask
            if best is None or front.sum() > best[2].sum():
                best = (R, tt.ravel(), front)
    return best


def _inliers_of(R, t, x_i, x_j, thr):
    return (np.abs(sampson_residuals(skew(t) @ R, x_i, x_j)) < thr) & chirality(R, t, x_i, x_j)


def _refine_robust(R, t, x_i, x_j, thr: float, min_inliers: int, kind: str):
    """Robust Sampson LM (``kind`` "cauchy" | "tukey", scale :data:`ROBUST_SCALE` x ``thr``) over every
    match in front of both cameras at the start, then the least-squares covariance over the inliers
    of the solution (``|r| < thr`` and in front).

    Why (our extension; measured in docs/studies/rop_consistency.md): with the hard gate, re-selecting inliers at
    the LM solution and re-fitting has more than one self-consistent fixed point when a few tens of
    tracks sit near the threshold (static rendering / LK errors of ~1 px): solution A keeps them,
    solution B drops them, and each fits its own set best. Image noise too small to move any track by
    more than 0.01 px then flips a ROP between the two (0.8 deg in direction on campus-short, 10 mm
    of one keyframe step's length). The robust weights (Cauchy ``1 / (1 + (r/c)^2)``, Tukey
    ``(1 - (r/c)^2)^2`` up to ``c``) have no step, so the solution moves continuously with the data."""
    front = chirality(R, t, x_i, x_j)
    R, t, cov5 = refine_essential(R, t, x_i[front], x_j[front], iters=20, robust=(kind, ROBUST_SCALE[kind] * thr))
    inl = _inliers_of(R, t, x_i, x_j, thr)
    if int(inl.sum()) >= max(min_inliers, 6):
        cov5 = sampson_cov(R, t, x_i[inl], x_j[inl])
    return R, t, cov5


PRIOR_AGREE_RAD = np.radians(1.0)   # the planar twin solutions seen were 3-50 deg apart


def _disambiguate(R, t, inliers, prior, x_i, x_j, thr):
    """RANSAC's ``(R, t, inliers)`` or the LM solution started from ``prior`` (``(R_i_j, rhat_i_j)``,
    project convention), whichever has more inliers (skipped when RANSAC's rotation is within 1 deg
    of the prior's); within 2 % the one whose rotation is closer to
    the prior's (the two planar solutions fit equally well; the prior picks the physical one)."""
    R_p = np.asarray(prior[0], float).T                        # OpenCV: R = R_j_i, t = -R_j_i rhat_i_j
    t_p = -R_p @ np.asarray(prior[1], float)
    if _angle(R @ R_p.T) < PRIOR_AGREE_RAD:                    # RANSAC agrees with the prediction
        return R, t, inliers
    sel = inliers if inliers.sum() >= 5 else np.ones(len(x_i), bool)
    R_q, t_q, _ = refine_essential(R_p, t_p, x_i[sel], x_j[sel], iters=5)
    inl_q = _inliers_of(R_q, t_q, x_i, x_j, thr)
    n_a, n_q = int(inliers.sum()), int(inl_q.sum())
    if n_q > 1.02 * n_a:
        return R_q, t_q, inl_q
    if n_q >= 0.98 * n_a and _angle(R_q @ R_p.T) < _angle(R @ R_p.T):
        return R_q, t_q, inl_q
    return R, t, inliers


def _angle(R: np.ndarray) -> float:
    return float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))


def _fail_reason(n: int, n_good: int, spread_px: float, min_inliers: int, R, t) -> str:
    if spread_px <= 2.0:
        return "inliers collapse to one image point (degenerate)"
    if n_good < min_inliers or not np.all(np.isfinite(R)) or np.linalg.norm(t) < 1e-12:
        return f"{n_good} inliers in front of both cameras < {min_inliers}"
    return ""


def estimate_rop_normalized(x_i: np.ndarray, x_j: np.ndarray, focal: float, seed: int = 0,
                            ransac_threshold_px: float = 1.0, prob: float = 0.999,
                            min_inliers: int = MIN_INLIERS, max_iters: int = 1000,
                            prior=None, loss: str = "gate") -> RopMeasurement:
    """ROP of image j in image i from undistorted normalized matches ``x_i``, ``x_j`` (N,2).

    RANSAC essential matrix (OpenCV's RANSAC, threshold ``ransac_threshold_px / focal``, ``max_iters`` upper bound
    on the adaptive iteration count, ``cv2.setRNGSeed(seed)`` first), the decomposition with most
    RANSAC inliers in front of both cameras (:func:`decompose`; like ``recoverPose`` but without its
    50 |t| distance cap, which rejects most points of a short forward step), Sampson LM on those
    inliers, re-selection of inliers (Sampson distance < threshold and in front), a second LM
    (``loss="gate"``, the default); or (``loss="cauchy" | "tukey"``, :func:`_refine_robust`) one robust LM
    over every match in front, whose inliers are then only counted. Fewer than ``min_inliers``
    inliers or a degenerate solve -> ``ok=False``."""
    if loss not in LOSSES:
        raise VoError(f"estimate_rop.loss: {loss!r}; valid: {', '.join(LOSSES)}")
    n = len(x_i)
    if len(x_j) != n:
        return failed_rop(n, f"point counts differ: {n} vs {len(x_j)}")
    if n < max(min_inliers, 5):
        return failed_rop(n, f"{n} correspondences < {max(min_inliers, 5)}")
    thr = ransac_threshold_px / focal
    cv2.setRNGSeed(int(seed))
    try:
        E, mask = cv2.findEssentialMat(x_i, x_j, np.eye(3), cv2.RANSAC, prob, thr, int(max_iters))
    except cv2.error as exc:
        return failed_rop(n, f"findEssentialMat failed: {str(exc).splitlines()[0]}")
    if E is None or mask is None or E.shape != (3, 3):
        return failed_rop(n, "findEssentialMat found no unique solution (degenerate points?)")
    R, t, inliers = decompose(E, x_i, x_j, mask.ravel() > 0)
    if prior is not None:
        R, t, inliers = _disambiguate(R, t, inliers, prior, x_i, x_j, thr)
    cov5 = None
    if int(inliers.sum()) >= min_inliers and _spread(x_i[inliers]) * focal > 2.0:
        if loss != "gate":
            R, t, cov5 = _refine_robust(R, t, x_i, x_j, thr, min_inliers, loss)
            inliers = _inliers_of(R, t, x_i, x_j, thr)
        else:
            R, t, r, J = _sampson_lm(R, t, x_i[inliers], x_j[inliers], 8, None)
            inliers = _inliers_of(R, t, x_i, x_j, thr)
            if int(inliers.sum()) >= min_inliers:
                R, t, cov5 = refine_essential(R, t, x_i[inliers], x_j[inliers], iters=3)
            else:                                  # the first fit's covariance only when no second fit replaces it
                cov5 = _ls_cov5(r, J)
    n_good = int(inliers.sum())
    reason = _fail_reason(n, int(n_good), _spread(x_i[inliers]) * focal, min_inliers, R, t)
    if reason or cov5 is None:
        return failed_rop(n, reason or "too few inliers for the Sampson refinement")
    R_i_j, rhat_i_j = rop_from_opencv(R, t)
    res = sampson_residuals(skew(t) @ R, x_i[inliers], x_j[inliers])
    return RopMeasurement(R_i_j, rhat_i_j, int(inliers.sum()), inliers, True, "",
                          float(np.sqrt(np.trace(cov5[:3, :3]) / 3.0)), float(np.sqrt(np.trace(cov5[3:, 3:]) / 2.0)),
                          float(np.sqrt(np.mean(res ** 2)) * focal), project_cov(R, t, cov5))


def estimate_rop(p_i: np.ndarray, p_j: np.ndarray, K_i: np.ndarray, dist_i, K_j: np.ndarray, dist_j,
                 seed: int = 0, ransac_threshold_px: float = 1.0, prob: float = 0.999,
                 min_inliers: int = MIN_INLIERS, **kw) -> RopMeasurement:
    """ROP of image j in image i from matched pixels ``p_i``, ``p_j`` (N,2) (distorted, as observed):
    undistort to normalized coordinates, then :func:`estimate_rop_normalized`."""
    p_i = np.asarray(p_i, dtype=float).reshape(-1, 2)
    p_j = np.asarray(p_j, dtype=float).reshape(-1, 2)
    if len(p_j) != len(p_i):
        return failed_rop(len(p_i), f"point counts differ: {len(p_i)} vs {len(p_j)}")
    x_i, x_j = normalized_points(p_i, K_i, dist_i), normalized_points(p_j, K_j, dist_j)
    focal = 0.25 * (K_i[0][0] + K_i[1][1] + K_j[0][0] + K_j[1][1])
    return estimate_rop_normalized(x_i, x_j, focal, seed, ransac_threshold_px, prob, min_inliers, **kw)
