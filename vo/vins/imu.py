"""IMU pre-integration between keyframes (seed 002 eq. 6-13) with gtsam's combined pre-integration.

gtsam's ``PreintegratedCombinedMeasurements`` carries the bias Jacobians (first-order bias correction, as
VINS-Mono) and the covariance; ``CombinedImuFactor`` is the residual of eq. 13 (position, velocity, rotation,
bias random walk). Gravity ``[0, 0, -9.81]`` in w (``MakeSharedU(9.81)``).

Samples are integrated with the midpoint rule as VINS-Mono does: each interval between two samples uses the
mean of the two gyro and accelerometer readings; the accelerometer reading is rotated by half the interval's
rotation so that gtsam's start-of-interval rotation applies it at the interval's midpoint (second-order
accurate, where a raw zero-order hold is first-order). Frame times between samples are handled by linear
interpolation of the readings.
"""
from __future__ import annotations

import gtsam
import numpy as np

from vo.errors import EstimatorError

GRAVITY = 9.81


def imu_params(config, rig_imu=None) -> gtsam.PreintegrationCombinedParams:
    """Kalibr continuous densities -> continuous-time covariances (density^2, CONVENTIONS.md).

    ``imu_noise="rig"``: the rig's (calibrated) densities, falling back to Table 1's when the rig has none
    (all zero); ``"table1"``: seed 002 Table 1 (``acc_n``, ``gyr_n``, ``acc_w``, ``gyr_w``).
    """
    dens = (config.acc_n, config.gyr_n, config.acc_w, config.gyr_w)
    if config.imu_noise == "rig" and rig_imu is not None:
        rig = (rig_imu.accel_noise_density, rig_imu.gyro_noise_density, rig_imu.accel_random_walk,
               rig_imu.gyro_random_walk)
        if min(rig) > 0:
            dens = rig
    acc_n, gyr_n, acc_w, gyr_w = dens
    p = gtsam.PreintegrationCombinedParams.MakeSharedU(GRAVITY)
    p.setAccelerometerCovariance(np.eye(3) * acc_n ** 2)
    p.setGyroscopeCovariance(np.eye(3) * gyr_n ** 2)
    p.setBiasAccCovariance(np.eye(3) * acc_w ** 2)
    p.setBiasOmegaCovariance(np.eye(3) * gyr_w ** 2)
    p.setIntegrationCovariance(np.eye(3) * 1e-8)
    return p


def check_imu(imu) -> None:
    """One-line EstimatorError for an unusable stream (missing, empty, out of order, non-finite)."""
    if imu is None or len(imu.t_ns) == 0:
        raise EstimatorError("vins: the dataset has no IMU (imu0/data.csv missing or empty); VINS needs imu0")
    t = np.asarray(imu.t_ns)
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise EstimatorError(f"vins: imu0 samples out of order or repeated at index {k} (t_ns {t[k - 1]} then "
                             f"{t[k]}); sort and de-duplicate imu0/data.csv")
    if not (np.all(np.isfinite(imu.gyro)) and np.all(np.isfinite(imu.accel))):
        raise EstimatorError("vins: imu0 has non-finite gyro/accel values")


class ImuStream:
    """The whole IMU stream with ``interval(t0, t1)``: sample times and readings covering [t0, t1]."""

    def __init__(self, imu, max_gap_s: float = 0.5):
        check_imu(imu)
        self.t = np.asarray(imu.t_ns, dtype=np.int64)
        self.f = np.hstack([np.asarray(imu.gyro, float), np.asarray(imu.accel, float)])
        self.max_gap_ns = int(max_gap_s * 1e9)

    def covers(self, t0_ns: int, t1_ns: int) -> bool:
        return bool(self.t[0] <= t0_ns and t1_ns <= self.t[-1])

    def interval(self, t0_ns: int, t1_ns: int) -> tuple:
        """(times (m,) int64 from t0 to t1, readings (m,6) [gyro, accel]) with interpolated end points."""
        if not self.covers(t0_ns, t1_ns):
            raise EstimatorError(f"vins: imu0 covers [{self.t[0]}, {self.t[-1]}] ns, not the frame interval "
                                 f"[{t0_ns}, {t1_ns}]")
        i0, i1 = np.searchsorted(self.t, t0_ns, "right"), np.searchsorted(self.t, t1_ns, "left")
        t_in = self.t[i0:i1]
        t = np.concatenate([[t0_ns], t_in, [t1_ns]]).astype(np.int64)
        f = np.vstack([self._at(t0_ns), self.f[i0:i1], self._at(t1_ns)])
        if len(t) > 1 and np.diff(t).max() > self.max_gap_ns:
            raise EstimatorError(f"vins: imu0 gap of {np.diff(t).max() * 1e-9:.3f} s near t_ns {t0_ns} "
                                 f"(> {self.max_gap_ns * 1e-9:.3f} s)")
        return t, f

    def _at(self, t_ns: int) -> np.ndarray:
        return np.array([np.interp(t_ns, self.t, self.f[:, k]) for k in range(6)])


def preintegrate(stream: ImuStream, params, t0_ns: int, t1_ns: int, bias: gtsam.imuBias.ConstantBias):
    """-> ``PreintegratedCombinedMeasurements`` from t0 to t1 (midpoint rule, see the module docstring)."""
    pim = gtsam.PreintegratedCombinedMeasurements(params, bias)
    t, f = stream.interval(t0_ns, t1_ns)
    bg = bias.gyroscope()
    for k in range(len(t) - 1):
        dt = (t[k + 1] - t[k]) * 1e-9
        if dt <= 0:
            continue
        w = 0.5 * (f[k, :3] + f[k + 1, :3])
        a = 0.5 * (f[k, 3:] + f[k + 1, 3:])
        a_mid = gtsam.Rot3.Expmap((w - bg) * (0.5 * dt)).matrix() @ a
        pim.integrateMeasurement(a_mid, w, dt)
    return pim
