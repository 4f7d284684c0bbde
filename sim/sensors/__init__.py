"""Sensors as a clean measurement of the smooth truth plus a separate noise step that takes its own
generator (OpenVINS's simulator; the generators come from :mod:`sim.rng`, one stream per sensor).

- :mod:`sim.sensors.imu`: ``measure(truth, imu)`` exact accelerometer and gyro (MuJoCo ``mj_inverse``,
  checked against the analytic formula); noise: :func:`sim.sensors.imu_noise.add_imu_noise`
  (streams ``imu_white``, ``imu_bias``).
- :mod:`sim.sensors.wheels`: ``measure(trajectory, dims, t_ns)`` wheel travel; noise:
  ``add_slip_noise`` (stream ``wheels``); ``encoder_ticks`` quantises.
- :mod:`sim.sensors.camera`: ``StereoCamera.measure(T_w_b)`` rendered images; noise: ``add_noise``
  (stream ``image_noise``, one generator per frame); ``FrameExposer`` adds the sensor effects
  (:mod:`~sim.sensors.effects_timing` blur and rolling shutter, :mod:`~sim.sensors.photometric`,
  :mod:`~sim.sensors.calib_error`, :mod:`~sim.sensors.effects_truth`; docs/sensor_effects.md).
"""
