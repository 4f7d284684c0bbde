"""Named IMU noise models (continuous-time Kalibr densities, see CONVENTIONS.md).

Units: white noise ``accel_noise_density`` m/s^2/sqrt(Hz), ``gyro_noise_density`` rad/s/sqrt(Hz);
bias random walk ``accel_random_walk`` m/s^3/sqrt(Hz), ``gyro_random_walk`` rad/s^2/sqrt(Hz).
Every model has ``T_b_i`` = identity; presets and overrides set the mounting.

- ``ideal``: all densities zero, 200 Hz (noise-free reference).
- ``euroc-adis16448``: the ADIS16448 of the EuRoC MAV datasets, values of ``mav0/imu0/sensor.yaml``.
- ``paper002``: seed 002, Table 1: n_a = 0.1, n_w = 0.01, b_a = 0.001, b_w = 0.0001. The table's
  units ('m/s2' for n_a and b_a, 'rad/s' for b_w, and the typo 'm/s' for the gyro noise n_w) are
  abbreviations; we read the four numbers as the VINS-Mono configuration parameters
  ``acc_n, gyr_n, acc_w, gyr_w``, i.e. continuous densities in m/s^2/sqrt(Hz), rad/s/sqrt(Hz),
  m/s^3/sqrt(Hz) and rad/s^2/sqrt(Hz). Rate 200 Hz. These are the *estimator's* assumed noise, not the
  sensor's (see ``xsens-mti10``): Table 1 lists them with F_c, s, M_s and n as "parameter values used in
  this study", and at 0.1 m/s^2/sqrt(Hz) the accelerometer density is 170 times the datasheet figure of
  the Xsens MTi 10 that recorded the paper's data (Section 5.1), as VINS-Mono's own configurations inflate
  the sensor's figures (its EuRoC file: acc_n 0.08 against the ADIS16448's 0.002). Simulating a sensor with
  them (``--set imu=paper002``) gives a far noisier IMU than the paper's vehicle carried.
- ``xsens-mti10``: the Xsens MTi 10 IMU that recorded seed 002's Urban Canyon data (Section 5.1: "An Xsens
  MTi 10 IMU was employed to collect raw IMU measurements at a frequency of 200 Hz"), from the sensor
  specifications of the MTi 10-series (Xsens, "MTi User Manual, MTi 10-series and MTi 100-series, 5th
  generation", document MT0605P, sensor specification table; the accelerometer figures are those the
  100-series shares, e.g. the MTi-300 datasheet, Movella 2023): gyroscope noise density 0.03 deg/s/sqrt(Hz)
  and in-run bias stability 18 deg/h; accelerometer noise density 60 ug/sqrt(Hz) and in-run bias stability
  15 ug (g = 9.80665 m/s^2). White noise: the densities converted to SI. The datasheet gives no bias random
  walk; the in-run bias stability B is the floor of the Allan deviation, reached at averaging times of the
  order of 100-1000 s. We take the random walk K whose Allan deviation K*sqrt(tau/3) equals B at
  tau = 300 s, i.e. K = B / (10 s^(1/2)): a walk that leaves B behind after a few minutes, an upper bound on
  the flicker floor over one of our routes (70-100 s). Rate 200 Hz, the paper's. This is the simulated
  sensor of the ``paper002`` rig; the estimator's assumed noise is a separate choice (``vins``'
  ``imu_noise``: the dataset's calibration, or Table 1).
"""
from __future__ import annotations

import math

from rigs.errors import RigError
from rigs.model import Imu

G0 = 9.80665                                  # standard gravity, the datasheet's g (m/s^2)
_DEG = math.pi / 180.0
_MTI10_ACC_NOISE_UG, _MTI10_ACC_BIAS_UG = 60.0, 15.0        # ug/sqrt(Hz), ug (in-run bias stability)
_MTI10_GYR_NOISE_DPS, _MTI10_GYR_BIAS_DPH = 0.03, 18.0      # deg/s/sqrt(Hz), deg/h (in-run bias stability)
_BIAS_STABILITY_TAU_S = 300.0                                # Allan time at which the random walk reaches B

IMU_MODELS: dict[str, Imu] = {
    "ideal": Imu(name="ideal", rate_hz=200.0, accel_noise_density=0.0, gyro_noise_density=0.0,
                 accel_random_walk=0.0, gyro_random_walk=0.0),
    "euroc-adis16448": Imu(name="euroc-adis16448", rate_hz=200.0,
                           accel_noise_density=2.0000e-3, gyro_noise_density=1.6968e-04,
                           accel_random_walk=3.0000e-3, gyro_random_walk=1.9393e-05),
    "paper002": Imu(name="paper002", rate_hz=200.0,
                    accel_noise_density=0.1, gyro_noise_density=0.01,
                    accel_random_walk=0.001, gyro_random_walk=0.0001),
    "xsens-mti10": Imu(name="xsens-mti10", rate_hz=200.0,
                       accel_noise_density=_MTI10_ACC_NOISE_UG * 1e-6 * G0,
                       gyro_noise_density=_MTI10_GYR_NOISE_DPS * _DEG,
                       accel_random_walk=_MTI10_ACC_BIAS_UG * 1e-6 * G0 / math.sqrt(_BIAS_STABILITY_TAU_S / 3),
                       gyro_random_walk=_MTI10_GYR_BIAS_DPH / 3600.0 * _DEG / math.sqrt(_BIAS_STABILITY_TAU_S / 3)),
}


def imu_model_names() -> list[str]:
    """Sorted names accepted by :func:`get_imu_model`."""
    return sorted(IMU_MODELS)


def get_imu_model(name: str) -> Imu:
    """Named IMU model (``T_b_i`` identity); unknown names raise RigError listing the valid ones."""
    try:
        return IMU_MODELS[name]
    except (KeyError, TypeError):
        raise RigError(f"imu model {name!r}: unknown; valid names: {', '.join(imu_model_names())}") from None
