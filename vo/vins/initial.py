"""Monocular visual-inertial initialisation as VINS-Mono (the start-up seed 002 relies on).

1. Up-to-scale SfM on the keyframes: essential matrix (OpenCV RANSAC) between the first keyframe with
   enough parallax and common features and the newest one, triangulation, PnP for the other keyframes,
   triangulation of the remaining tracks, then a short gtsam bundle adjustment (Huber, gauge by priors).
   Frame ``v`` = the camera frame of the reference keyframe.
2. Gyro bias: ``scipy.optimize.least_squares`` on the pre-integrated vs SfM relative rotations.
3. Velocities, gravity ``g_v`` and scale ``s``: linear least squares (``numpy.linalg.lstsq``) on the
   pre-integration equations (eq. 10-11), then the same equations with ``|g| = 9.81`` (gravity refinement).
   The scale is observable only through acceleration: the initialisation is accepted when the scale's
   relative standard deviation (from the least-squares residual) is below ``init_max_scale_std``;
   otherwise the oldest keyframe is dropped and the next keyframe retried (at constant speed it waits).
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import gtsam
import numpy as np
from scipy.optimize import least_squares

from vo.vins.imu import GRAVITY, preintegrate


@dataclass
class InitResult:
    ref: int                  # index of the reference keyframe (frame v)
    R_v_c: np.ndarray         # (n,3,3) camera rotations in v
    p_v_c: np.ndarray         # (n,3) camera positions in v, SfM units
    points: dict              # track id -> (3,) point in v, SfM units
    bg: np.ndarray
    scale: float
    g_v: np.ndarray           # gravity (pointing down) in v, |g| = 9.81
    v_v: np.ndarray           # (n,3) IMU velocities in v, metric


def _common(a, b):
    common, ia, ib = np.intersect1d(a.ids, b.ids, assume_unique=True, return_indices=True)
    return common, a.xy[ia], b.xy[ib]


def _triangulate(T_c_v_a, T_c_v_b, xa, xb):
    P = cv2.triangulatePoints(T_c_v_a[:3], T_c_v_b[:3], xa.T.astype(float), xb.T.astype(float))
    X = (P[:3] / P[3]).T
    za = (T_c_v_a[:3, :3] @ X.T).T[:, 2] + T_c_v_a[2, 3]
    zb = (T_c_v_b[:3, :3] @ X.T).T[:, 2] + T_c_v_b[2, 3]
    return X, (za > 0) & (zb > 0) & np.all(np.isfinite(X), axis=1)


def sfm(frames, min_parallax_px: float, virtual_focal: float):
    """-> (ref, T_c_v (n,4,4), points {track: p_v}) or None when no keyframe pair qualifies."""
    last = frames[-1]
    for ref in range(len(frames) - 1):
        ids, xa, xb = _common(frames[ref], last)
        if len(ids) >= 30 and np.linalg.norm(xa - xb, axis=1).mean() * virtual_focal >= min_parallax_px:
            break
    else:
        return None
    E, inl = cv2.findEssentialMat(xa, xb, np.eye(3), cv2.RANSAC, 0.999, 0.3 / virtual_focal)
    if E is None or E.shape != (3, 3):
        return None
    n_in, R, t, inl = cv2.recoverPose(E, xa, xb, np.eye(3), mask=inl)
    if n_in < 20:
        return None
    n = len(frames)
    T = np.full((n, 4, 4), np.nan)
    T[ref], T[-1] = np.eye(4), np.eye(4)
    T[-1][:3, :3], T[-1][:3, 3] = R, t.ravel()
    points = {}
    _add_points(points, frames, T, ref, n - 1)
    for k in list(range(ref + 1, n - 1)) + list(range(ref - 1, -1, -1)):
        if not _pnp(frames[k], points, T, k):
            return None
        _add_points(points, frames, T, k, n - 1 if k > ref else ref)
    for k in range(n):
        _add_points(points, frames, T, k, ref)
    return ref, _bundle_adjust(frames, T, points, ref, virtual_focal)


def _add_points(points, frames, T, a, b):
    if a == b:
        return
    ids, xa, xb = _common(frames[a], frames[b])
    new = np.array([i not in points for i in ids], bool)
    if not new.any():
        return
    X, ok = _triangulate(T[a], T[b], xa[new], xb[new])
    for i, p in zip(ids[new][ok], X[ok]):
        points[int(i)] = p


def _pnp(frame, points, T, k) -> bool:
    have = [(p, xy) for i, xy in zip(frame.ids, frame.xy) if (p := points.get(int(i))) is not None]
    if len(have) < 10:
        return False
    obj = np.array([h[0] for h in have], float)
    img = np.array([h[1] for h in have], float)
    ok, rvec, tvec, inl = cv2.solvePnPRansac(obj, img, np.eye(3), None, reprojectionError=2.0 / 460.0,
                                             iterationsCount=100, flags=cv2.SOLVEPNP_EPNP)
    if not ok or inl is None or len(inl) < 8:
        return False
    ok, rvec, tvec = cv2.solvePnP(obj[inl.ravel()], img[inl.ravel()], np.eye(3), None, rvec, tvec, True,
                                  cv2.SOLVEPNP_ITERATIVE)
    T[k] = np.eye(4)
    T[k][:3, :3], T[k][:3, 3] = cv2.Rodrigues(rvec)[0], tvec.ravel()
    return True


def _bundle_adjust(frames, T_c_v, points, ref, virtual_focal):
    """Short gtsam BA on normalized coordinates (K = virtual focal), poses T_v_c; returns (T_c_v, points)."""
    from gtsam.symbol_shorthand import L, X
    K = gtsam.Cal3_S2(virtual_focal, virtual_focal, 0.0, 0.0, 0.0)
    noise = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(1.345),
                                           gtsam.noiseModel.Isotropic.Sigma(2, 1.5))
    g, v = gtsam.NonlinearFactorGraph(), gtsam.Values()
    for k, fr in enumerate(frames):
        v.insert(X(k), gtsam.Pose3(np.linalg.inv(T_c_v[k])))
        for i, xy in zip(fr.ids, fr.xy):
            if int(i) in points:
                g.add(gtsam.GenericProjectionFactorCal3_S2(xy * virtual_focal, noise, X(k), L(int(i)), K))
    for i, p in points.items():
        v.insert(L(i), gtsam.Point3(*p))
    tight = gtsam.noiseModel.Isotropic.Sigma(6, 1e-6)
    g.add(gtsam.PriorFactorPose3(X(ref), gtsam.Pose3(), tight))
    last = len(frames) - 1       # scale gauge: left to LM's damping, then the reference baseline is restored
    d0 = float(np.linalg.norm(np.linalg.inv(T_c_v[last])[:3, 3]))
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(100)
    opt = gtsam.LevenbergMarquardtOptimizer(g, v, params)
    out = opt.optimize()
    T = np.array([np.linalg.inv(out.atPose3(X(k)).matrix()) for k in range(len(frames))])
    d1 = float(np.linalg.norm(np.linalg.inv(T[last])[:3, 3]))
    f = d0 / d1 if d1 > 0 else 1.0
    T[:, :3, 3] *= f
    return T, {i: out.atPoint3(L(i)) * f for i in points}


def gyro_bias(stream, params, frames, R_v_i) -> np.ndarray:
    """bg minimising the pre-integrated vs visual relative rotations."""
    pims = [preintegrate(stream, params, a.t_ns, b.t_ns, gtsam.imuBias.ConstantBias())
            for a, b in zip(frames[:-1], frames[1:])]

    def res(bg):
        b = gtsam.imuBias.ConstantBias(np.zeros(3), bg)
        out = []
        for k, pim in enumerate(pims):
            dR = pim.predict(gtsam.NavState(), b).attitude().matrix()
            out.append(gtsam.Rot3.Logmap(gtsam.Rot3(dR.T @ R_v_i[k].T @ R_v_i[k + 1])))
        return np.concatenate(out)
    return least_squares(res, np.zeros(3)).x


def align(stream, params, frames, R_v_c, p_v_c, T_i_c, bg):
    """Velocities (n,3), gravity g_v (3,) with |g| = 9.81, scale s (VINS-Mono LinearAlignment + RefineGravity)."""
    n = len(frames)
    R_c_i, p_c_i = np.linalg.inv(T_i_c)[:3, :3], np.linalg.inv(T_i_c)[:3, 3]
    R_v_i = R_v_c @ R_c_i
    bias = gtsam.imuBias.ConstantBias(np.zeros(3), bg)
    rows, rhs = [], []
    nx = 3 * n + 4                                   # v_0..v_n-1, g, s
    for k in range(n - 1):
        pim = preintegrate(stream, params, frames[k].t_ns, frames[k + 1].t_ns, bias)
        dt = pim.deltaTij()
        dp, dv = R_v_i[k] @ pim.deltaPij(), R_v_i[k] @ pim.deltaVij()
        lever = (R_v_c[k + 1] - R_v_c[k]) @ p_c_i
        A = np.zeros((6, nx))
        # s (p_c(k+1) - p_c(k)) - v_k dt - 0.5 g dt^2 = R dp - lever
        A[:3, nx - 1] = p_v_c[k + 1] - p_v_c[k]
        A[:3, 3 * k:3 * k + 3] = -np.eye(3) * dt
        A[:3, 3 * n:3 * n + 3] = -0.5 * np.eye(3) * dt * dt
        # v_(k+1) - v_k - g dt = R dv
        A[3:, 3 * (k + 1):3 * (k + 1) + 3] = np.eye(3)
        A[3:, 3 * k:3 * k + 3] = -np.eye(3)
        A[3:, 3 * n:3 * n + 3] = -np.eye(3) * dt
        rows.append(A)
        rhs.append(np.concatenate([dp - lever, dv]))
    A, b = np.vstack(rows), np.concatenate(rhs)
    x, rss, *_ = np.linalg.lstsq(A, b, rcond=None)
    g_lin = x[3 * n:3 * n + 3]
    dof = max(A.shape[0] - A.shape[1], 1)
    cov = np.linalg.pinv(A.T @ A) * float(np.sum((A @ x - b) ** 2)) / dof
    rel_std = float(np.sqrt(cov[-1, -1]) / max(abs(x[-1]), 1e-12))

    def res(y):                                      # gravity on the sphere |g| = 9.81
        g = GRAVITY * y[3 * n:3 * n + 3] / np.linalg.norm(y[3 * n:3 * n + 3])
        z = np.concatenate([y[:3 * n], g, y[-1:]])
        return A @ z - b
    y = least_squares(res, x).x
    g = GRAVITY * y[3 * n:3 * n + 3] / np.linalg.norm(y[3 * n:3 * n + 3])
    return y[:3 * n].reshape(n, 3), g, float(y[-1]), float(np.linalg.norm(g_lin)), rel_std


def initialize(stream, params, frames, T_i_c, config):
    """Run SfM + alignment on keyframes ``frames`` (FeatureFrames); -> InitResult or None (with reason)."""
    got = sfm(frames, config.init_min_parallax_px, config.virtual_focal)
    if got is None:
        return None, "SfM failed (parallax or features too few)"
    ref, (T_c_v, points) = got
    T_v_c = np.linalg.inv(T_c_v)
    R_v_c, p_v_c = T_v_c[:, :3, :3], T_v_c[:, :3, 3]
    R_v_i = R_v_c @ np.linalg.inv(T_i_c)[:3, :3]
    bg = gyro_bias(stream, params, frames, R_v_i)
    v_v, g_v, s, g_norm, rel_std = align(stream, params, frames, R_v_c, p_v_c, T_i_c, bg)
    if not (s > 0 and abs(g_norm - GRAVITY) < 1.0 and np.all(np.isfinite(v_v))):
        return None, f"alignment failed (scale {s:.3g}, |g| {g_norm:.3g} m/s^2)"
    if rel_std > config.init_max_scale_std:
        return None, f"scale not observable yet (relative std {rel_std:.3f} > {config.init_max_scale_std})"
    return InitResult(ref, R_v_c, p_v_c, points, bg, s, g_v, v_v), "ok"
