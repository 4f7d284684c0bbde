"""Monocular visual-inertial initialisation as VINS-Mono (the start-up seed 002 relies on).

1. Up-to-scale SfM on the keyframes (VINS-Mono's ``relativePose`` + ``GlobalSFM``, :mod:`vo.vins.sfm`): essential
   matrix between a reference keyframe and the newest (or, when none pairs with it, the next-newest that does),
   PnP for the other keyframes, triangulation, gtsam bundle adjustment. Frame ``v`` = the camera frame of the
   reference keyframe.
2. Gyro bias: ``scipy.optimize.least_squares`` on the pre-integrated vs SfM relative rotations.
3. Velocities, gravity ``g_v`` and scale ``s`` (VINS-Mono's ``LinearAlignment``): linear least squares
   (``numpy.linalg.lstsq``) on the pre-integrated Delta-p and Delta-v (eq. 10-11; no differentiation of the
   SfM positions), then the same equations with ``|g| = 9.81`` (``RefineGravity``: here a least-squares fit
   over the gravity direction on the sphere, the minimiser VINS-Mono's tangent-plane iterations approach).
   The scale is observable only through changes of the acceleration (a constant specific force is explained
   equally well by a tilted gravity and a scaled path). The initialisation is accepted when the scale's
   relative standard deviation (noise model of :func:`align`) times ``init_scale_sigmas`` is within
   ``init_max_scale_std`` and the
   scale agrees within the same fraction with the reverse regression (:func:`_reverse_scale`): noise in the
   SfM positions pulls the linear alignment's scale towards zero without raising its residual-based
   standard deviation much. After a failure the estimator keeps the window long in time
   (:func:`vo.vins.estimator.drop_init_keyframe`).
"""
from __future__ import annotations

from dataclasses import dataclass

import gtsam
import numpy as np
from scipy.optimize import least_squares

from vo.vins.imu import GRAVITY, preintegrate
from vo.vins.sfm import sfm

SFM_FAILED = "SfM failed (parallax or features too few)"


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
    scale_rel_std: float = float("nan")   # the alignment's relative standard deviation of s
    provisional: bool = False             # accepted only as a provisional start (the window must confirm it)


def usable_points(result: InitResult, frames, min_parallax_deg: float = 1.0, depth_m=(0.1, 1e3)) -> dict:
    """The SfM points that can start the window: seen by >= 2 keyframes, in front of each at a metric depth
    within ``depth_m``, and with >= ``min_parallax_deg`` between the rays of the first and last observer (the
    test new landmarks pass later). Points at near-infinite depth or seen once leave the window's linear
    system indeterminate."""
    T_v_c = np.tile(np.eye(4), (len(frames), 1, 1))
    T_v_c[:, :3, :3], T_v_c[:, :3, 3] = result.R_v_c, result.scale * np.asarray(result.p_v_c)
    T_c_v = np.linalg.inv(T_v_c)
    cos_min = np.cos(np.radians(min_parallax_deg))
    out = {}
    for i, p in result.points.items():
        obs = [k for k, fr in enumerate(frames) if i in fr.id_set]
        if len(obs) < 2:
            continue
        p_m = result.scale * np.asarray(p, float)
        z = T_c_v[obs, 2, :3] @ p_m + T_c_v[obs, 2, 3]
        ra, rb = p_m - T_v_c[obs[0], :3, 3], p_m - T_v_c[obs[-1], :3, 3]
        if np.all((z > depth_m[0]) & (z < depth_m[1])) and ra @ rb <= cos_min * np.linalg.norm(ra) * np.linalg.norm(rb):
            out[i] = p
    return out


def window_scale_change(result: InitResult, T_w_c: np.ndarray) -> float:
    """How far the window's first visual-inertial optimisation moved the start's scale: least-squares ratio of
    the window's camera distances from its first state (``T_w_c`` (n,4,4), the start's keyframes in order) to
    those of the aligned SfM (``scale * p_v_c``), minus 1. The alignment's standard deviation assumes
    independent SfM position noise; a keyframe the SfM placed wrongly (in traffic: the keyframe at standstill,
    posed by PnP on tracks partly on moving cars) biases it beyond that, and the window, which weighs each
    observation against the IMU, then moves the scale away from it."""
    d_a = np.linalg.norm(result.scale * (result.p_v_c - result.p_v_c[0]), axis=1)
    d_w = np.linalg.norm(T_w_c[:, :3, 3] - T_w_c[0, :3, 3], axis=1)
    return float(np.sum(d_w * d_a) / max(np.sum(d_a ** 2), 1e-12) - 1.0)


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
    """Velocities (n,3), gravity g_v (3,) with |g| = 9.81, scale s (VINS-Mono LinearAlignment + RefineGravity),
    weighted by the noise of the equations. -> (v_v, g_v, s, |g| of the linear solution, relative standard
    deviation of s, s of the reverse regression, SfM position noise tau in m).

    The equations are VINS-Mono's (eq. 10-11 of seed 002 on keyframe intervals: Delta-p and Delta-v against
    the SfM positions scaled by s); VINS-Mono solves them with identity weights. Here each interval's
    (Delta-p, Delta-v) carries its pre-integration covariance (gtsam ``preintMeasCov``, the IMU densities in
    use, rotated into v), and the SfM positions an isotropic noise tau (metric, per coordinate; the rows of
    consecutive intervals share a position, so their covariance is the difference operator's D D^T tau^2),
    with tau the smallest value that brings chi^2 / dof to 1 (0 when the IMU noise alone explains the
    residual). The scale's standard deviation is then that of the noise model, not of the unweighted
    residual: with identity weights the residual is dominated by the short intervals' small errors and
    the standard deviation of s comes out several times too small (measured on an 8-s start from rest
    with seed 002's Table 1 IMU and the true poses: 3.5 % from the unweighted residual, 8.6 % from the
    noise model, actual error of the unweighted solution 27 %, of the weighted one 5 %)."""
    n = len(frames)
    R_c_i, p_c_i = np.linalg.inv(T_i_c)[:3, :3], np.linalg.inv(T_i_c)[:3, 3]
    R_v_i = R_v_c @ R_c_i
    bias = gtsam.imuBias.ConstantBias(np.zeros(3), bg)
    rows, rhs = [], []
    nx = 3 * n + 4                                   # v_0..v_n-1, g, s
    m = 6 * (n - 1)
    C_imu = np.zeros((m, m))
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
        R6 = np.kron(np.eye(2), R_v_i[k])
        C_imu[6 * k:6 * k + 6, 6 * k:6 * k + 6] = R6 @ pim.preintMeasCov()[3:9, 3:9] @ R6.T
    A, b = np.vstack(rows), np.concatenate(rhs)
    D = np.zeros((m, 3 * n))                         # position rows: p(k+1) - p(k)
    for k in range(n - 1):
        D[6 * k:6 * k + 3, 3 * (k + 1):3 * (k + 2)] = np.eye(3)
        D[6 * k:6 * k + 3, 3 * k:3 * k + 3] = -np.eye(3)
    C_sfm = D @ D.T
    dof = max(m - nx, 1)

    def solve(tau):
        L = np.linalg.cholesky(C_imu + tau ** 2 * C_sfm + 1e-12 * np.eye(m))
        Aw, bw = np.linalg.solve(L, A), np.linalg.solve(L, b)
        x = np.linalg.lstsq(Aw, bw, rcond=None)[0]
        return x, Aw, bw, float(np.sum((Aw @ x - bw) ** 2)) / dof

    tau = 0.0
    x, Aw, bw, chi2 = solve(tau)
    if chi2 > 1.0:                                   # the SfM noise level that explains the residual
        lo, hi = 0.0, 1.0
        for _ in range(40):
            tau = 0.5 * (lo + hi)
            if solve(tau)[3] > 1.0:
                lo = tau
            else:
                hi = tau
        tau = hi
        x, Aw, bw, chi2 = solve(tau)
    s_reverse = _reverse_scale(A, b, n)
    g_lin = x[3 * n:3 * n + 3]
    cov = np.linalg.pinv(Aw.T @ Aw)
    rel_std = float(np.sqrt(cov[-1, -1]) / max(abs(x[-1]), 1e-12))

    def res(y):                                      # gravity on the sphere |g| = 9.81
        g = GRAVITY * y[3 * n:3 * n + 3] / np.linalg.norm(y[3 * n:3 * n + 3])
        z = np.concatenate([y[:3 * n], g, y[-1:]])
        return Aw @ z - bw
    y = least_squares(res, x).x
    g = GRAVITY * y[3 * n:3 * n + 3] / np.linalg.norm(y[3 * n:3 * n + 3])
    return y[:3 * n].reshape(n, 3), g, float(y[-1]), float(np.linalg.norm(g_lin)), rel_std, s_reverse, tau


def _reverse_scale(A, b, n) -> float:
    """Scale of the same equations solved with the SfM positions as the observations (unknowns v/s, g/s, 1/s).

    The linear alignment puts the noisy SfM displacements in the design matrix (``s * dp_sfm``), so noise in
    them biases s towards zero (errors in variables); this reverse regression is biased the other way. The two
    agree only when the acceleration changes carry the scale well above the SfM noise (``initialize``)."""
    nx = 3 * n + 4
    A2, b2 = A.copy(), b.copy()
    pos = np.zeros(len(b), bool)
    for k in range(n - 1):
        pos[6 * k:6 * k + 3] = True
    # position rows: s*dp_sfm - v dt - g dt^2/2 = imu  ->  dp_sfm = (v/s) dt + (g/s) dt^2/2 + (1/s) imu
    A2[pos, :nx - 1], A2[pos, nx - 1], b2[pos] = -A[pos, :nx - 1], b[pos], A[pos, nx - 1]
    # velocity rows: v' - v - g dt = imu  ->  0 = (v'/s) - (v/s) - (g/s) dt - (1/s) imu
    A2[~pos, nx - 1], b2[~pos] = -b[~pos], 0.0
    y = np.linalg.lstsq(A2, b2, rcond=None)[0]
    return float(1.0 / y[-1]) if abs(y[-1]) > 1e-12 else float("inf")


def imu_excitation(stream, params, frames) -> float:
    """Acceleration excitation of the window (m/s^2): VINS-Mono's ``initialStructure`` check, the standard
    deviation over the keyframe intervals of the mean specific force Delta-v / Delta-t (body frame of each
    interval's start; sample std of the vector, ``sqrt(sum |a_k - mean|^2 / (n - 1))``), less the part the
    accelerometer's white noise alone gives it: each interval mean carries ``3 acc_sigma^2 / dt_k`` of noise
    variance (``acc_sigma`` the continuous density in ``params``, m/s^2/sqrt(Hz)), subtracted from the variance.
    VINS-Mono computes this with a 0.25 m/s^2 threshold but only logs it ("IMU excitation not enough!");
    here it gates the attempt when ``init_min_excitation`` > 0 (default 0, as VINS-Mono) and is reported in
    the refusal messages. Without the noise term, seed 002's Table 1 IMU (0.1 m/s^2/sqrt(Hz)) on 0.2-s
    keyframe intervals would show about 0.39 m/s^2 at constant speed, where the scale is not observable."""
    acc_sigma = float(np.sqrt(params.getAccelerometerCovariance()[0, 0]))
    a, noise = [], []
    for f0, f1 in zip(frames[:-1], frames[1:]):
        pim = preintegrate(stream, params, f0.t_ns, f1.t_ns, gtsam.imuBias.ConstantBias())
        dt = pim.deltaTij()
        a.append(pim.deltaVij() / dt)
        noise.append(3.0 * acc_sigma ** 2 / dt)
    a = np.array(a)
    if len(a) < 2:
        return 0.0
    var = float(np.sum((a - a.mean(axis=0)) ** 2) / (len(a) - 1))
    return float(np.sqrt(max(var - float(np.mean(noise)), 0.0)))


def initialize(stream, params, frames, T_i_c, config):
    """Run SfM + alignment on keyframes ``frames`` (FeatureFrames); -> InitResult or None (with reason).

    With ``config.init_min_excitation`` > 0, tried only when the window's :func:`imu_excitation` reaches it.
    Needs the alignment's gravity magnitude within 1 m/s^2 of 9.81 and s > 0 (VINS-Mono's
    ``LinearAlignment`` test). Accepted when ``init_scale_sigmas`` times the scale's relative standard deviation
    (noise model of :func:`align`) is within ``init_max_scale_std`` (the target) and the forward and reverse regressions agree within it;
    accepted as ``provisional`` (the estimator then emits no pose until its window confirms the scale) when
    the standard deviation is below ``init_provisional_scale_std`` and that option is on (above
    ``init_max_scale_std``; equal to it, the default, is off: a window whose forward and reverse regressions
    disagree is then refused, not started provisionally)."""
    exc = imu_excitation(stream, params, frames)
    if config.init_min_excitation > 0 and exc < config.init_min_excitation:
        return None, (f"IMU excitation not enough ({exc:.3f} < {config.init_min_excitation} m/s^2 above the "
                      f"noise): scale not observable")
    got = sfm(frames, config.init_min_parallax_px, config.virtual_focal)
    if got is None:
        return None, SFM_FAILED
    ref, (T_c_v, points) = got
    T_v_c = np.linalg.inv(T_c_v)
    R_v_c, p_v_c = T_v_c[:, :3, :3], T_v_c[:, :3, 3]
    R_v_i = R_v_c @ np.linalg.inv(T_i_c)[:3, :3]
    bg = gyro_bias(stream, params, frames, R_v_i)
    v_v, g_v, s, g_norm, rel_std, s_reverse, tau = align(stream, params, frames, R_v_c, p_v_c, T_i_c, bg)
    if not (s > 0 and abs(g_norm - GRAVITY) < 1.0 and np.all(np.isfinite(v_v))):
        return None, f"alignment failed (scale {s:.3g}, |g| {g_norm:.3g} m/s^2)"
    agree = abs(s / s_reverse - 1.0) <= config.init_max_scale_std
    bound = config.init_scale_sigmas * rel_std
    if bound <= config.init_max_scale_std and agree:
        return InitResult(ref, R_v_c, p_v_c, points, bg, s, g_v, v_v, rel_std), "ok"
    provisional_on = config.init_provisional_scale_std > config.init_max_scale_std
    if provisional_on and bound <= config.init_provisional_scale_std:
        return InitResult(ref, R_v_c, p_v_c, points, bg, s, g_v, v_v, rel_std, True), "provisional"
    if bound > config.init_max_scale_std:
        return None, (f"scale not observable yet ({config.init_scale_sigmas:g} x relative std {rel_std:.3f} > "
                      f"{config.init_provisional_scale_std}, SfM noise {100 * tau:.1f} cm, IMU excitation "
                      f"{exc:.2f} m/s^2)")
    return None, (f"scale not observable yet (forward {s:.4g} and reverse {s_reverse:.4g} regressions "
                  f"differ by more than {config.init_max_scale_std})")
