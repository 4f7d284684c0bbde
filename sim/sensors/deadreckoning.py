"""Dead-reckoning EKF: gyro-integrated attitude with accelerometer tilt updates, wheel odometry for
the distance travelled along the body x axis.

State ``x = (p_w (3), roll, pitch, yaw, b, b_g (3), b_a (2))`` (Euler ZYX, ``R_w_b = R_z(yaw) R_y(pitch) R_x(roll)``;
``b`` the slip bias, the fraction of the wheel distance that was not travelled; ``b_g`` the gyro
bias in b, rad/s; ``b_a`` the accelerometer bias along body x and y, m/s^2), filterpy's
:class:`~filterpy.kalman.ExtendedKalmanFilter` with a nonlinear prediction per IMU interval
``[t_k, t_k+1]``: ``R <- R Exp((omega_b - b_g) dt)``, ``p <- p + R ((1 - b) ds, 0, 0)`` with ``ds`` the mean
of the two wheels' distances over the interval (cumulative ticks interpolated at the IMU times). The
Jacobians are central differences.

How filterpy is used: each step sets ``F`` (the Jacobian of the motion model) and ``Q``, then calls
filterpy's ``predict(u)``, which propagates ``P = F P F^T + Q``; a tilt measurement sets ``R`` and
calls filterpy's ``update(z, HJacobian, Hx, residual)``. The state itself is moved by the motion
model ``f``, not by ``F x``: filterpy's default ``predict_x`` is linear (``x = F x + B u``), and
here ``F`` is only the Jacobian of ``f`` (the attitude composes rotations, the position turns the
wheel distance by the attitude), so ``F x`` would not be the motion. filterpy's documentation names
``predict_x`` as the method to override for such a model; :class:`MotionEKF` does that, with
``u = (omega_b, dt, ds)``. Process noise: white gyro noise (``gyro_noise_density^2 dt``),
white wheel slip (``(slip_std ds)^2`` plus the tick quantum) and a random walk of the slip bias
(``slip_bias_walk^2 dt``) and of the gyro bias (``gyro_bias_walk^2 dt``, the IMU's Kalibr
``gyro_random_walk``; without it the yaw covariance misses the bias drift: 12 deg of yaw error
against a 0.3 deg sigma after 115 m / 990 s with the ADIS16448 model). The slip bias starts at ``slip_bias_mean`` with standard deviation
``slip_bias_std``: nothing observes it, so the estimate stays there while its variance makes the
position covariance grow in proportion to the distance, as the error of a wheel odometer with a
common slip does (white slip per interval alone averages out and gives a covariance ~40x too small). Update: roll and pitch from the
accelerometer (gravity direction) when ``| |a| - g |`` is below ``tilt_gate_mps2``. Gyro biases are
not estimated (a rover calibrates them at rest).

Vertical: the height error is the integral of the pitch error over the distance, so the vertical
covariance is only as right as the tilt covariance. Two tilt-measurement errors are in the model
(without them the tilt sigma was 0.27 deg while the pitch was off by up to 1.1 deg, and the vertical
error reached 4 sigma on ``yutu-traverse`` seed 1): (1) the accelerometer bias, which enters the
tilt measurement as ``roll + b_ay / g``, ``pitch - b_ax / g`` and is as correlated as the bias itself
(a random walk ``accel_bias_walk``, the IMU's Kalibr ``accelerometer_random_walk``: 1 deg of tilt after
1000 s with the ADIS16448); averaging many static updates does not remove it; (2) while the rover
moves, vibration and the mast's lever arm: on the lunar drive the accepted (gated) tilt
measurements are off by 3 deg (std) while moving against 0.06 deg at rest, so a moving update
uses ``tilt_sigma_moving_rad`` and a static one (no wheel travel since the last update)
``tilt_sigma_rad``. Output covariances use the pose tangent of
:mod:`vo.crosssite.types` (right perturbation, ``rot_b``, ``trans_b``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter

from rigs.geometry import make_T, so3_exp, so3_log
from sim.errors import SimError

G = 9.81
N_X = 12                               # state size


@dataclass(frozen=True)
class DeadReckoningConfig:
    """Noise and wheel parameters (SI units). ``wheel_radius_m``, ``ticks_per_rev`` as in ``rig.wheels``."""

    wheel_radius_m: float
    ticks_per_rev: int
    gyro_noise_density: float = 1e-4   # rad/s/sqrt(Hz)
    slip_std: float = 0.01             # relative distance error per interval (1 sigma)
    tilt_sigma_rad: float = 0.005      # accelerometer tilt measurement at rest (white part)
    tilt_sigma_moving_rad: float = 0.06  # the same while the wheels turn (vibration, lever arm)
    tilt_gate_mps2: float = 0.3
    tilt_update_every: int = 20        # IMU samples between tilt updates
    slip_bias_mean: float = 0.0        # prior slip bias (fraction of wheel distance not travelled)
    slip_bias_std: float = 0.10        # its 1-sigma: the uncalibrated mean slip
    slip_bias_walk: float = 0.018      # 1/sqrt(s) random-walk density of the bias (slowly varying slip)
    gyro_bias_std: float = 0.0         # rad/s, initial gyro bias 1-sigma (0: calibrated at the start)
    gyro_bias_walk: float = 0.0        # rad/s/sqrt(s), gyro bias random walk (Kalibr gyro_random_walk)
    accel_bias_std: float = 0.0        # m/s^2, initial accelerometer bias 1-sigma (x, y)
    accel_bias_walk: float = 0.0       # m/s^2/sqrt(s), its random walk (Kalibr accelerometer_random_walk)

    def __post_init__(self):
        for f in ("wheel_radius_m", "tilt_sigma_rad", "tilt_sigma_moving_rad", "tilt_gate_mps2"):
            if not float(getattr(self, f)) > 0:
                raise SimError(f"deadreckoning.{f}: must be positive, got {getattr(self, f)!r}")
        if not -1.0 < float(self.slip_bias_mean) < 1.0:
            raise SimError(f"deadreckoning.slip_bias_mean: must be in (-1, 1), got {self.slip_bias_mean!r}")
        for f in ("gyro_noise_density", "slip_std", "slip_bias_std", "slip_bias_walk",
                  "gyro_bias_std", "gyro_bias_walk", "accel_bias_std", "accel_bias_walk"):
            if not float(getattr(self, f)) >= 0:
                raise SimError(f"deadreckoning.{f}: must be non-negative, got {getattr(self, f)!r}")
        for f in ("ticks_per_rev", "tilt_update_every"):
            if int(getattr(self, f)) < 1:
                raise SimError(f"deadreckoning.{f}: must be a positive integer, got {getattr(self, f)!r}")


def R_from_euler(rpy) -> np.ndarray:
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def euler_from_R(R) -> np.ndarray:
    return np.array([np.arctan2(R[2, 1], R[2, 2]), -np.arcsin(np.clip(R[2, 0], -1, 1)), np.arctan2(R[1, 0], R[0, 0])])


def _f(x, omega_b, dt, ds):
    R = R_from_euler(x[3:6])
    R1 = R @ so3_exp((np.asarray(omega_b) - x[7:10]) * dt)
    return np.r_[x[:3] + R @ np.array([(1.0 - x[6]) * ds, 0.0, 0.0]), euler_from_R(R1), x[6:]]


def _num_jac(fun, x0, eps=1e-6):
    f0 = fun(x0)
    J = np.empty((f0.size, x0.size))
    for k in range(x0.size):
        d = np.zeros(x0.size)
        d[k] = eps
        diff = fun(x0 + d) - fun(x0 - d)
        if f0.size == N_X:
            diff[3:6] = (diff[3:6] + np.pi) % (2 * np.pi) - np.pi
        J[:, k] = diff / (2 * eps)
    return J


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


class MotionEKF(ExtendedKalmanFilter):
    """filterpy's EKF whose state prediction is the nonlinear motion model :func:`_f` (filterpy's
    extension point for a model ``F x`` does not describe); ``predict(u)`` with ``u = (omega_b (3,),
    dt [s], ds [m])`` then propagates ``P = F P F^T + Q`` as filterpy does."""

    def predict_x(self, u=0):
        omega_b, dt, ds = u
        self.x = _f(self.x, omega_b, dt, ds)


@dataclass(frozen=True)
class DeadReckoning:
    """Filter output at the IMU times: ``t_ns`` (N,), ``T_w_b`` (N,4,4), ``cov`` (N,6,6) (rot_b, trans_b)."""

    t_ns: np.ndarray
    T_w_b: np.ndarray
    cov: np.ndarray

    def at(self, t_ns) -> tuple:
        """(T_w_b (M,4,4), cov (M,6,6)) at the output sample nearest each of ``t_ns``."""
        t = np.atleast_1d(np.asarray(t_ns, np.int64))
        if t.min() < self.t_ns[0] or t.max() > self.t_ns[-1]:
            raise SimError(f"dead reckoning: requested times outside [{self.t_ns[0]}, {self.t_ns[-1]}] ns")
        k = np.clip(np.searchsorted(self.t_ns, t), 1, len(self.t_ns) - 1)
        k = np.where(t - self.t_ns[k - 1] < self.t_ns[k] - t, k - 1, k)
        return self.T_w_b[k], self.cov[k]


def _tangent_cov(x, P) -> np.ndarray:
    """Covariance of the state (p_w, euler) -> pose tangent (rot_b, trans_b) by a numerical Jacobian."""
    x, P = x[:6], P[:6, :6]
    R0 = R_from_euler(x[3:])

    def g(xx):
        R = R_from_euler(xx[3:])
        return np.r_[so3_log(R0.T @ R), R0.T @ (xx[:3] - x[:3])]
    J = _num_jac(g, x)
    return J @ P @ J.T


def dead_reckon(imu, wheels, R_b_i: np.ndarray, T_w_b0: np.ndarray, P0: np.ndarray,
                cfg: DeadReckoningConfig) -> DeadReckoning:
    """Run the EKF from ``T_w_b0`` (state covariance ``P0`` (6,6) over (p_w, roll, pitch, yaw); the slip
    bias from ``cfg.slip_bias_mean``/``slip_bias_std``) over the
    IMU samples ``imu`` (t_ns, gyro, accel in the IMU frame, rotated to b by ``R_b_i``) and the wheel
    ticks ``wheels`` (t_ns, left_ticks, right_ticks)."""
    t = np.asarray(imu.t_ns, np.int64)
    if len(t) < 2 or np.any(np.diff(t) <= 0):
        raise SimError("dead reckoning: need two or more strictly increasing IMU times")
    if wheels.t_ns[0] > t[0] or wheels.t_ns[-1] < t[-1]:
        raise SimError("dead reckoning: wheel ticks must cover the IMU time span")
    gyro_b, acc_b = np.asarray(imu.gyro) @ R_b_i.T, np.asarray(imu.accel) @ R_b_i.T
    per_tick = 2 * np.pi * cfg.wheel_radius_m / cfg.ticks_per_rev
    dist = 0.5 * (np.asarray(wheels.left_ticks) + np.asarray(wheels.right_ticks)) * per_tick
    s = np.interp(t.astype(float), np.asarray(wheels.t_ns, float), dist)
    ekf = MotionEKF(dim_x=N_X, dim_z=2)
    ekf.x = np.r_[T_w_b0[:3, 3], euler_from_R(T_w_b0[:3, :3]), cfg.slip_bias_mean, np.zeros(5)]
    ekf.P = np.zeros((N_X, N_X))
    ekf.P[:6, :6] = np.asarray(P0, float)
    ekf.P[6, 6] = max(cfg.slip_bias_std ** 2, 1e-12)
    ekf.P[7:10, 7:10] = np.eye(3) * max(cfg.gyro_bias_std ** 2, 1e-16)
    ekf.P[10:, 10:] = np.eye(2) * max(cfg.accel_bias_std ** 2, 1e-16)
    H = np.zeros((2, N_X))                  # (roll + b_ay / g, pitch - b_ax / g)
    H[0, 3] = H[1, 4] = 1.0
    H[0, 11], H[1, 10] = 1.0 / G, -1.0 / G
    out_T, out_P = [make_T(R_from_euler(ekf.x[3:6]), ekf.x[:3])], [_tangent_cov(ekf.x, ekf.P)]
    for k in range(len(t) - 1):
        dt = (t[k + 1] - t[k]) * 1e-9
        w = 0.5 * (gyro_b[k] + gyro_b[k + 1])
        ds = s[k + 1] - s[k]
        x0 = ekf.x.copy()
        ekf.F = _num_jac(lambda xx: _f(xx, w, dt, ds), x0)
        G_n = _num_jac(lambda n: _f(x0, w + n[:3], dt, ds + n[3]) + np.r_[np.zeros(6), n[4:]], np.zeros(10))
        q = np.r_[[cfg.gyro_noise_density ** 2 / dt] * 3, (cfg.slip_std * ds) ** 2 + per_tick ** 2 / 6,
                  cfg.slip_bias_walk ** 2 * dt, [cfg.gyro_bias_walk ** 2 * dt] * 3, [cfg.accel_bias_walk ** 2 * dt] * 2]
        ekf.Q = G_n @ np.diag(q) @ G_n.T
        ekf.predict(u=(w, dt, ds))
        a = acc_b[k + 1]
        if (k + 1) % cfg.tilt_update_every == 0 and abs(np.linalg.norm(a) - G) < cfg.tilt_gate_mps2:
            moving = s[k + 1] - s[max(k + 1 - cfg.tilt_update_every, 0)] > 0.5 * per_tick
            ekf.R = np.eye(2) * (cfg.tilt_sigma_moving_rad if moving else cfg.tilt_sigma_rad) ** 2
            z = np.array([np.arctan2(a[1], a[2]), np.arctan2(-a[0], np.hypot(a[1], a[2]))])
            ekf.update(z, lambda xx: H, lambda xx: H @ xx, residual=lambda p, q2: _wrap(p - q2))
        ekf.x[3:6] = _wrap(ekf.x[3:6])
        out_T.append(make_T(R_from_euler(ekf.x[3:6]), ekf.x[:3]))
        out_P.append(_tangent_cov(ekf.x, ekf.P))
    return DeadReckoning(t.copy(), np.array(out_T), np.array(out_P))
