"""The ``realistic`` sensor-effects preset: values typical of the EuRoC MAV cameras (Aptina MT9V034, a
global-shutter 752x480 sensor hardware-synchronised with the IMU, auto exposure) and of seed 000's rig.

Which values are measured and which assumed (docs/sensor_effects.md): the global shutter (no rolling
shutter) is the MT9V034's; the sensor noise (shot-noise gain 0.0276 grey levels per electron, no read
noise beyond the 8-bit rounding) is fitted to the noise-per-brightness curve
(:func:`vo.frontend.noise_level.noise_level_curve`) of 190 real EuRoC V1_01 cam0/cam1 frames
(``docs/studies/euroc_noise_calibration.py``); exposure, vignetting strength, time offset, jitter and
calibration error magnitudes are assumed typical values (EuRoC publishes none of them per frame).
"""
from __future__ import annotations

import dataclasses

from sim.generate_config import CalibError, CameraEffects, GenerateConfig, ImuClock

REALISTIC_CAMERA = CameraEffects(exposure_ms=4.0, blur_subframes=5, line_delay_us=0.0, timestamp_jitter_us=20.0,
                                 vignetting=0.5, auto_exposure=True, ae_target=0.45, ae_time_constant_s=0.3,
                                 read_noise_dn=0.0, shot_noise_gain=0.0276)
REALISTIC_IMU_CLOCK = ImuClock(time_offset_ms=1.0)
REALISTIC_CALIB_ERROR = CalibError(focal_ppm=200.0, principal_px=0.3, dist_rel=0.02, extrinsic_rot_deg=0.02,
                                   extrinsic_trans_mm=0.3)


def realistic(config: GenerateConfig) -> GenerateConfig:
    """``config`` with the ``realistic`` camera effects, IMU clock offset and calibration error."""
    return dataclasses.replace(config, camera=REALISTIC_CAMERA, imu_clock=REALISTIC_IMU_CLOCK,
                               calib_error=REALISTIC_CALIB_ERROR)
