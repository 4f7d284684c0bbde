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
  m/s^3/sqrt(Hz) and rad/s^2/sqrt(Hz). Rate 200 Hz.
"""
from __future__ import annotations

from rigs.errors import RigError
from rigs.model import Imu

IMU_MODELS: dict[str, Imu] = {
    "ideal": Imu(name="ideal", rate_hz=200.0, accel_noise_density=0.0, gyro_noise_density=0.0,
                 accel_random_walk=0.0, gyro_random_walk=0.0),
    "euroc-adis16448": Imu(name="euroc-adis16448", rate_hz=200.0,
                           accel_noise_density=2.0000e-3, gyro_noise_density=1.6968e-04,
                           accel_random_walk=3.0000e-3, gyro_random_walk=1.9393e-05),
    "paper002": Imu(name="paper002", rate_hz=200.0,
                    accel_noise_density=0.1, gyro_noise_density=0.01,
                    accel_random_walk=0.001, gyro_random_walk=0.0001),
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
