"""Bundle adjustment over all images of both sites, seed 001 eq. 4-5, with gtsam.

Unknowns: the current site's body pose ``X(1)`` and the tie points ``L(p)``. Observations (eq. 4,
collinearity of the tie points): one ``GenericStereoFactor3D`` per tie point and pair,
``StereoPoint2(u_l, u_r, v)`` with ``Cal3_S2Stereo``: the stereo relative orientation of eq. 5 is
exact inside the rectified stereo model. The mast rotations (eq. 5): with ``mast_sigma_* = 0``
(default) the paper's hard constraint ``C t + W = 0``, each pair's factor acting on the body pose
through ``body_P_sensor = T_b_c0``; with a positive sigma (a mast calibration error to absorb) one
pose per pair ``C(s, j)`` tied to the body by ``BetweenFactorPose3(X(s), C(s, j), T_b_c0)``. (A
near-zero sigma there makes the system too stiff for gtsam's Cholesky, hence the two forms.) The
previous site is fixed by a tight ``PriorFactorPose3`` (``FIXED_SIGMA``): ``NonlinearEqualityPose3``
gives an infinite error as soon as Levenberg-Marquardt's damping moves ``X(0)``, so LM stalls, and
its constrained linearization is rejected by ``Marginals``' Cholesky. Image observations are robust
(Huber); observations whose residual exceeds ``reject_px`` after a first solution are dropped and the
graph solved again (a point whose observations are all downweighted would leave it indeterminate).
Cross-site matching error (``xsite_sigma_px`` > 0): the current site's observation of a tie is where
the cross-site match put it, and its stereo match follows that left pixel, so a matching error moves
``u_l`` and ``u_r`` together and ``v``: its covariance is ``sigma_px^2 I + xsite_sigma_px^2 J`` with
``J = [[1, 1, 0], [1, 1, 0], [0, 0, 1]]`` (order u_l, u_r, v). This is seed 001's split of the errors
into the stereo parallax error sigma_p (1/3 px, ZNCC + LSM) and the cross-site matching error
sigma_theta (eq. 8; "accuracy of ASIFT matching is up to 3 pixel"), carried from eq. 9-13 into the
BA's observation weights. The residual test is in units of ``sigma_px`` after whitening, so a
current-site observation is rejected by its own covariance.
Output: the pose of ``X(1)`` and its ``Marginals`` covariance (gtsam ``Pose3`` tangent: rot_b, trans_b).
"""
from __future__ import annotations

from dataclasses import dataclass

import gtsam
import numpy as np
from gtsam.symbol_shorthand import C, L, X

from vo.errors import VoError

FIXED_SIGMA = 1e-7   # rad, m: the previous site's pose prior, negligible against any tie-point geometry


@dataclass(frozen=True)
class TieObservations:
    """``site`` (M,) 0 previous / 1 current, ``pair`` (M,) pair index in that site, ``point`` (M,)
    tie-point id in 0..N-1, ``uv_l`` (M,2) left-image pixel, ``u_r`` (M,) right-image column."""

    site: np.ndarray
    pair: np.ndarray
    point: np.ndarray
    uv_l: np.ndarray
    u_r: np.ndarray


@dataclass(frozen=True)
class BundleResult:
    T_w_b: np.ndarray
    cov: np.ndarray
    rms_px: float
    iterations: int
    n_points: int = 0


def _pose(T) -> gtsam.Pose3:
    return gtsam.Pose3(np.asarray(T, dtype=float))


def _cam_key(site: int, pair: int) -> int:
    return C(1000 * int(site) + int(pair))


def stereo_noise(sigma_px: float, huber_k: float, xsite_sigma_px: float = 0.0):
    """Huber-robust noise of a stereo observation (u_l, u_r, v): isotropic ``sigma_px``, plus the
    cross-site matching error ``xsite_sigma_px`` common to u_l and u_r and on v (module docstring)."""
    if xsite_sigma_px > 0:
        J = np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
        base = gtsam.noiseModel.Gaussian.Covariance(sigma_px ** 2 * np.eye(3) + xsite_sigma_px ** 2 * J)
    else:
        base = gtsam.noiseModel.Isotropic.Sigma(3, sigma_px)
    return gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(huber_k), base)


def build_graph(T_w_b_prev, T_b_c0_sites, obs: TieObservations, K: np.ndarray, baseline: float,
                sigma_px: float, huber_k: float, mast_sigma_rad: float, mast_sigma_m: float,
                xsite_sigma_px: float = 0.0):
    """The factor graph of eq. 4-5 (see the module docstring)."""
    g = gtsam.NonlinearFactorGraph()
    g.add(gtsam.PriorFactorPose3(X(0), _pose(T_w_b_prev), gtsam.noiseModel.Isotropic.Sigma(6, FIXED_SIGMA)))
    soft = _soft_mast(mast_sigma_rad, mast_sigma_m)
    if soft:
        mast = gtsam.noiseModel.Diagonal.Sigmas(np.r_[[mast_sigma_rad] * 3, [mast_sigma_m] * 3])
        for s, T_b_c0s in enumerate(T_b_c0_sites):
            for j in sorted(set(obs.pair[obs.site == s].tolist())):
                g.add(gtsam.BetweenFactorPose3(X(s), _cam_key(s, j), _pose(T_b_c0s[j]), mast))
    cal = gtsam.Cal3_S2Stereo(K[0, 0], K[1, 1], 0.0, K[0, 2], K[1, 2], baseline)
    noise = (stereo_noise(sigma_px, huber_k), stereo_noise(sigma_px, huber_k, xsite_sigma_px))
    for s, j, p, (u, v), ur in zip(obs.site, obs.pair, obs.point, obs.uv_l, obs.u_r):
        m, px = gtsam.StereoPoint2(u, ur, v), noise[int(s)]
        if soft:
            g.add(gtsam.GenericStereoFactor3D(m, px, _cam_key(s, j), L(int(p)), cal))
        else:
            g.add(gtsam.GenericStereoFactor3D(m, px, X(int(s)), L(int(p)), cal, _pose(T_b_c0_sites[s][j])))
    return g


def _soft_mast(mast_sigma_rad: float, mast_sigma_m: float) -> bool:
    return mast_sigma_rad > 0 or mast_sigma_m > 0


def initial_values(T_w_b_prev, T_w_b_cur, T_b_c0_sites, obs: TieObservations, P_w: np.ndarray,
                   soft: bool = True) -> gtsam.Values:
    v = gtsam.Values()
    for s, T in enumerate((T_w_b_prev, T_w_b_cur)):
        v.insert(X(s), _pose(T))
        for j in sorted(set(obs.pair[obs.site == s].tolist())) if soft else ():
            v.insert(_cam_key(s, j), _pose(np.asarray(T) @ T_b_c0_sites[s][j]))
    for p in sorted(set(obs.point.tolist())):
        v.insert(L(int(p)), gtsam.Point3(*P_w[p]))
    return v


def bundle_adjust(T_w_b_prev, T_w_b_cur0, T_b_c0_sites, obs: TieObservations, P_w0: np.ndarray, K, baseline,
                  sigma_px: float = 1 / 3, huber_k: float = 1.345, mast_sigma_rad: float = 0.0,
                  mast_sigma_m: float = 0.0, max_iterations: int = 50, reject_px: float = 3.0,
                  xsite_sigma_px: float = 0.0) -> BundleResult:
    """Levenberg-Marquardt (gtsam) on the graph of :func:`build_graph`; -> pose and covariance of X(1).
    ``rms_px``: the RMS whitened residual per image coordinate, in units of ``sigma_px``."""
    if not np.any(obs.site == 1) or not np.any(obs.site == 0):
        raise VoError("bundle_adjust: observations at both sites are required")
    g = build_graph(T_w_b_prev, T_b_c0_sites, obs, np.asarray(K, float), baseline, sigma_px, huber_k,
                    mast_sigma_rad, mast_sigma_m, xsite_sigma_px)
    soft = _soft_mast(mast_sigma_rad, mast_sigma_m)
    v0 = initial_values(T_w_b_prev, T_w_b_cur0, T_b_c0_sites, obs, P_w0, soft)
    res, iters = _optimize(g, v0, max_iterations)
    keep = _inlier_observations(g, res, obs, sigma_px, reject_px)
    if not np.all(keep):   # second pass without the rejected observations (and their lonely points)
        obs = TieObservations(*(a[keep] for a in (obs.site, obs.pair, obs.point, obs.uv_l, obs.u_r)))
        both = set(obs.point[obs.site == 0].tolist()) & set(obs.point[obs.site == 1].tolist())
        k2 = np.isin(obs.point, list(both))
        obs = TieObservations(*(a[k2] for a in (obs.site, obs.pair, obs.point, obs.uv_l, obs.u_r)))
        if len(both) < 3:
            raise VoError(f"bundle_adjust: {len(both)} tie points left after rejecting residuals > {reject_px} px")
        g = build_graph(T_w_b_prev, T_b_c0_sites, obs, np.asarray(K, float), baseline, sigma_px, huber_k,
                        mast_sigma_rad, mast_sigma_m, xsite_sigma_px)
        res, iters = _optimize(g, initial_values(T_w_b_prev, res.atPose3(X(1)).matrix(), T_b_c0_sites, obs,
                                                 _points(res, P_w0), soft), max_iterations)
    cov = np.asarray(gtsam.Marginals(g, res).marginalCovariance(X(1)))
    n_obs = len(obs.site)
    rms = float(np.sqrt(2.0 * g.error(res) / (3 * n_obs))) * sigma_px if n_obs else float("nan")
    return BundleResult(res.atPose3(X(1)).matrix(), np.asarray(cov), rms, iters, len(set(obs.point.tolist())))


def _optimize(g, v0, max_iterations):
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(int(max_iterations))
    params.setRelativeErrorTol(1e-14)
    params.setAbsoluteErrorTol(1e-20)
    opt = gtsam.LevenbergMarquardtOptimizer(g, v0, params)
    return opt.optimize(), int(opt.iterations())


def _points(values, P_w0):
    P = np.array(P_w0, float)
    for p in range(len(P)):
        if values.exists(L(p)):
            P[p] = values.atPoint3(L(p))
    return P


def _inlier_observations(g, values, obs, sigma_px, reject_px) -> np.ndarray:
    """(M,) bool: stereo observations whose residual (whitened, in units of ``sigma_px``: pixels for the
    isotropic noise) is below ``reject_px``; the stereo factors follow the equality and mast factors."""
    first = g.size() - len(obs.site)
    r = np.array([np.sqrt(2.0 * g.at(first + k).error(values)) for k in range(len(obs.site))]) * sigma_px
    return r <= reject_px
