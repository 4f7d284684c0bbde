"""The truth of the sensor effects, written next to the dataset and never shown to ``cmd:`` estimators
(:mod:`vo.estimators.sensor_view` copies an allow-list of sensor files only):

- ``rig_true.yaml``: the rig the images were rendered with, when ``calib_error`` is set (``rig.yaml``,
  ``sensor.yaml``, ``camchain.yaml`` and KITTI ``calib.txt`` then carry the perturbed one);
- ``sensor_effects.yaml``: the IMU time offset ``td`` in ns (``t_imu = t_cam + td``) and the drawn
  calibration errors per camera;
- ``frame_effects.csv``: per frame, the written stamp, the true time (mid-exposure of the centre row,
  which the cam0 ground truth refers to), the blur length over the exposure (the largest over a 3 x 3
  grid of pixels: for points at 5 m depth, and at infinity; :func:`sim.sensors.effects_timing.blur_lengths_px`)
  and the auto exposure gain.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rigs.atomic_io import atomic_write_text
from rigs.rig_yaml import save_rig
from sim.sensors.effects_timing import blur_lengths_px

FRAME_HEADER = "#stamp [ns],t_true [ns],blur_5m [px],blur_inf [px],gain"


def time_offset_ns(config) -> int:
    """``imu.time_offset_ms`` in integer ns."""
    return int(round(config.imu_clock.time_offset_ms * 1e6))


def write_calibration_truth(out_dir, rig_true, draws: np.ndarray, config) -> None:
    """``rig_true.yaml`` and ``sensor_effects.yaml`` (module docstring), when any IMU-clock or calibration
    effect is set."""
    import yaml
    err, out = config.calib_error, Path(out_dir)
    if not err.active and time_offset_ns(config) == 0:
        return
    doc = {"imu_time_offset_ns": time_offset_ns(config), "calib_error": {}}
    if err.active:
        save_rig(rig_true, out / "rig_true.yaml")
        for cam, z in zip(rig_true.cameras, draws):
            doc["calib_error"][cam.name] = {
                "fx_rel": float(err.focal_ppm * 1e-6 * z[0]), "fy_rel": float(err.focal_ppm * 1e-6 * z[1]),
                "cx_px": float(err.principal_px * z[2]), "cy_px": float(err.principal_px * z[3]),
                "dist_rel": [float(err.dist_rel * v) for v in z[4:9]],
                "rot_deg": [float(err.extrinsic_rot_deg * v) for v in z[9:12]],
                "trans_mm": [float(err.extrinsic_trans_mm * v) for v in z[12:15]]}
        if err.stereo_disparity_px and len(rig_true.cameras) > 1:
            doc["calib_error"][rig_true.cameras[-1].name]["cx_px"] -= float(err.stereo_disparity_px)
    atomic_write_text(out / "sensor_effects.yaml", yaml.safe_dump(doc, sort_keys=True))


def write_frame_effects(out_dir, setup, gains) -> None:
    """``frame_effects.csv`` (module docstring) when any camera effect is set."""
    e, rig = setup.config.camera, setup.rig
    if e == type(e)():
        return
    t = setup.frame_t_ns
    half = int(round(e.exposure_ms * 0.5e6))
    T_b_c0 = rig.cameras[0].T_b_c_array
    poses = [setup.trajectory.states(t + dt).T_w_b @ T_b_c0 for dt in (-half, half, 0)]
    near, far = blur_lengths_px(*poses, rig.cameras[0])
    g = np.ones(len(t)) if gains is None else np.asarray(gains, float)
    rows = [FRAME_HEADER] + [f"{s},{tt},{a!r},{b!r},{c!r}" for s, tt, a, b, c in
                             zip(setup.frame_stamp_ns.tolist(), t.tolist(), near.tolist(), far.tolist(), g.tolist())]
    atomic_write_text(Path(out_dir) / "frame_effects.csv", "\n".join(rows) + "\n")
