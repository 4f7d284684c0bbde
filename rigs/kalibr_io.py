"""Kalibr's calibration files, both ways: ``camchain-imucam.yaml`` (cameras, ``T_cam_imu``, ``T_cn_cnm1``,
``timeshift_cam_imu``) and ``imu.yaml`` (noise densities, random walks, ``T_i_b``). The frame and distortion
conventions at this boundary are listed in :mod:`rigs.calib_io`; writers are atomic, readers raise one-line
RigErrors naming the file and the field."""
from __future__ import annotations

import dataclasses

import numpy as np

from rigs.atomic_io import atomic_write_text
from rigs.calib_io import (_matrix_field, _opencv_dist, _radtan_k3, _resolution, _rigid, _rows, dropped_k3_note,
                           int_if_integral)
from rigs.config_io import dump_yaml, read_yaml_file
from rigs.errors import RigError
from rigs.geometry import inv_T
from rigs.imu_models import get_imu_model
from rigs.model import Camera, Imu, Rig
from rigs.calib_fields import check_keys, field_error, field_floats, field_number

KALIBR_CAMCHAIN = "camchain-imucam.yaml"
KALIBR_IMU = "imu.yaml"


def kalibr_dropped_k3(rig: Rig) -> list[str]:
    """One line per camera whose ``k3 != 0``, which Kalibr's 4-coefficient radtan cannot hold."""
    return [dropped_k3_note(c, f"cam{k} ({c.name})") for k, c in enumerate(rig.cameras) if _radtan_k3(c) != 0.0]


def kalibr_camchain_dict(rig: Rig, timeshift_s: float = 0.0) -> dict:
    """Rig -> Kalibr ``camchain-imucam`` dict: per ``camK`` the pinhole intrinsics ``[fu, fv, pu, pv]``,
    ``radtan`` ``[k1, k2, r1, r2]`` (4 values, as Kalibr defines it: a non-zero ``k3`` is dropped, see
    :func:`kalibr_dropped_k3`), ``resolution``, ``T_cam_imu`` = ``T_c_i``, ``T_cn_cnm1`` =
    ``T_cK_cK-1`` (K > 0), ``timeshift_cam_imu`` [s] (``t_imu = t_cam + shift``) and ``rostopic``."""
    T_b_i = rig.imu.T_b_i_array
    out = {}
    for k, cam in enumerate(rig.cameras):
        T_c_b = inv_T(cam.T_b_c_array)
        entry = {"camera_model": "pinhole", "intrinsics": [cam.fx, cam.fy, cam.cx, cam.cy],
                 "distortion_model": "equidistant" if cam.is_fisheye else "radtan",
                 "distortion_coeffs": [float(x) for x in cam.dist[:4]],
                 "resolution": [cam.width, cam.height], "T_cam_imu": _rows(T_c_b @ T_b_i)}
        if k > 0:
            entry["T_cn_cnm1"] = _rows(T_c_b @ rig.cameras[k - 1].T_b_c_array)
            entry["cam_overlaps"] = [k - 1]
        elif len(rig.cameras) > 1:
            entry["cam_overlaps"] = [1]
        entry.update({"timeshift_cam_imu": float(timeshift_s), "rostopic": f"/cam{k}/image_raw"})
        out[f"cam{k}"] = entry
    return out


def kalibr_imu_dict(imu: Imu) -> dict:
    """Imu -> Kalibr ``imu.yaml`` dict (``imu0``); ``T_i_b`` = inv(``T_b_i``) maps the vehicle body
    frame into the IMU frame (identity where the body is the IMU, as Kalibr's single-IMU files)."""
    return {"imu0": {"T_i_b": _rows(inv_T(imu.T_b_i_array)),
                     "accelerometer_noise_density": imu.accel_noise_density,
                     "accelerometer_random_walk": imu.accel_random_walk,
                     "gyroscope_noise_density": imu.gyro_noise_density,
                     "gyroscope_random_walk": imu.gyro_random_walk,
                     "model": "calibrated", "rostopic": "/imu0", "time_offset": 0.0,
                     "update_rate": int_if_integral(imu.rate_hz)}}


def _kalibr_header(rig: Rig, what: str) -> str:
    lines = [f"Kalibr {what} of rig {rig.name} (https://github.com/ethz-asl/kalibr/wiki/yaml-formats)."]
    if what == "imu":
        return lines[0] + "\nT_i_b maps the vehicle body frame into the IMU frame (inv(T_b_i) of rig.yaml)."
    lines.append(f"Camera rate {int_if_integral(rig.camera_rate_hz)} Hz (Kalibr has no field for it; reading this "
                 f"file, give it with --set camera_rate_hz=...).")
    dropped = kalibr_dropped_k3(rig)
    if dropped:
        lines += ["NOT EXACT: this rig cannot be expressed in Kalibr's models. Kalibr's radtan has 4 coefficients",
                  "[k1, k2, r1, r2]; the rig's radial k3 is dropped here: " + "; ".join(dropped) + ".",
                  "rig.yaml holds the exact calibration (OpenCV k1 k2 p1 p2 k3)."]
    return "\n".join(lines)


def write_kalibr(rig: Rig, camchain_path, imu_path=None, timeshift_s: float = 0.0) -> None:
    """Write Kalibr ``camchain-imucam.yaml`` (and ``imu.yaml`` if ``imu_path``), atomically. A rig with
    ``k3 != 0`` gets a comment saying that Kalibr's 4-coefficient radtan drops it."""
    atomic_write_text(camchain_path, dump_yaml(kalibr_camchain_dict(rig, timeshift_s),
                                               header=_kalibr_header(rig, "camchain-imucam")))
    if imu_path is not None:
        atomic_write_text(imu_path, dump_yaml(kalibr_imu_dict(rig.imu), header=_kalibr_header(rig, "imu")))


_KALIBR_CAM_REQ = ("camera_model", "intrinsics", "distortion_model", "distortion_coeffs", "resolution")
_KALIBR_CAM_OPT = ("T_cam_imu", "T_imu_cam", "T_cn_cnm1", "timeshift_cam_imu", "rostopic", "cam_overlaps")


def _kalibr_camera(d, k, T_c_prev_b, source) -> Camera:
    """One ``camK`` entry -> Camera with ``T_b_c`` in the IMU (=body) frame."""
    p = f"cam{k}"
    check_keys(d, _KALIBR_CAM_REQ, _KALIBR_CAM_OPT, source, p)
    if d["camera_model"] != "pinhole":
        raise field_error(source, f"{p}.camera_model", f"only 'pinhole' is supported, got {d['camera_model']!r}")
    if d["distortion_model"] not in ("radtan", "equidistant"):
        raise field_error(source, f"{p}.distortion_model",
                          f"only 'radtan' and 'equidistant' are supported, got {d['distortion_model']!r}")
    fisheye = d["distortion_model"] == "equidistant"
    fu, fv, pu, pv = field_floats(d["intrinsics"], source, f"{p}.intrinsics", (4,))
    w, h = _resolution(d["resolution"], source, f"{p}.resolution")
    if "T_cam_imu" in d:
        T_b_c = inv_T(np.asarray(_matrix_field(d["T_cam_imu"], source, f"{p}.T_cam_imu")))
    elif "T_imu_cam" in d:     # OpenVINS' variant of the Kalibr file
        T_b_c = np.asarray(_matrix_field(d["T_imu_cam"], source, f"{p}.T_imu_cam"))
    elif "T_cn_cnm1" in d and T_c_prev_b is not None:
        T_b_c = inv_T(np.asarray(_matrix_field(d["T_cn_cnm1"], source, f"{p}.T_cn_cnm1")) @ T_c_prev_b)
    elif k == 0:
        T_b_c = np.eye(4)
    else:
        raise field_error(source, f"{p}.T_cam_imu", "missing field (and no T_cn_cnm1)")
    coeffs = field_floats(d["distortion_coeffs"], source, f"{p}.distortion_coeffs", (4,) if fisheye else (4, 5))
    return Camera(name=p, width=w, height=h, fx=fu, fy=fv, cx=pu, cy=pv,
                  dist=tuple(coeffs) if fisheye else _opencv_dist(coeffs),
                  dist_model="equidistant" if fisheye else "radtan",
                  T_b_c=_rigid(T_b_c, source, f"{p}.T_cam_imu"))


def read_kalibr_imu(imu_path) -> Imu:
    """Kalibr ``imu.yaml`` (``imu0:`` section, or the fields at top level) -> Imu with
    ``T_b_i = inv(T_i_b)`` (identity without ``T_i_b``)."""
    source = str(imu_path)
    d = read_yaml_file(imu_path)
    if isinstance(d, dict) and "imu0" in d:
        d, p = d["imu0"], "imu0"
    else:
        p = ""
    keys = ("accelerometer_noise_density", "accelerometer_random_walk", "gyroscope_noise_density",
            "gyroscope_random_walk", "update_rate")
    check_keys(d, keys, ("rostopic", "model", "T_i_b", "time_offset"), source, p)
    v = {k: field_number(d[k], source, f"{p}.{k}" if p else k, nonneg=True) for k in keys}
    T_b_i = np.eye(4)
    if "T_i_b" in d:
        T_b_i = inv_T(np.asarray(_matrix_field(d["T_i_b"], source, f"{p}.T_i_b" if p else "T_i_b")))
    try:
        return Imu(name="kalibr", rate_hz=v["update_rate"], T_b_i=T_b_i, accel_noise_density=v["accelerometer_noise_density"],
                   gyro_noise_density=v["gyroscope_noise_density"], accel_random_walk=v["accelerometer_random_walk"],
                   gyro_random_walk=v["gyroscope_random_walk"])
    except RigError as exc:
        raise RigError(f"{source}: {exc}") from None


def is_kalibr_camchain(path) -> bool:
    """True when the YAML file at ``path`` is a Kalibr camchain (a top-level ``cam0:`` mapping)."""
    try:
        d = read_yaml_file(path)
    except RigError:
        return False
    return isinstance(d, dict) and isinstance(d.get("cam0"), dict)


def read_kalibr(camchain_path, imu_path=None, name: str = "kalibr", camera_rate_hz: float = 20.0,
                mount: str = "kalibr") -> Rig:
    """Kalibr camchain (+ optional imu.yaml) -> Rig.

    The body frame is the IMU frame, or, when ``imu.yaml`` has ``T_i_b`` (as ours do), the frame
    ``T_i_b`` maps from: cameras get ``T_b_c = inv(T_i_b) @ inv(T_cam_imu)``. Without ``imu_path`` the
    IMU is the ``ideal`` model at the body origin. Kalibr has no camera rate: ``camera_rate_hz``.
    ``timeshift_cam_imu`` is a property of the recording, not of the rig: see :func:`read_kalibr_timeshift`.
    """
    source = str(camchain_path)
    d = read_yaml_file(camchain_path)
    if not isinstance(d, dict) or "cam0" not in d:
        raise field_error(source, "cam0", "missing field (expected cam0:, cam1:, ... sections)")
    cams, T_c_prev_b = [], None
    for k in range(len(d)):
        if f"cam{k}" not in d:
            raise field_error(source, sorted(set(d) - {f"cam{j}" for j in range(k)})[0],
                              "unknown key; valid keys: cam0, cam1, ... (consecutive)")
        cams.append(_kalibr_camera(d[f"cam{k}"], k, T_c_prev_b, source))
        T_c_prev_b = inv_T(cams[-1].T_b_c_array)
    imu = get_imu_model("ideal") if imu_path is None else read_kalibr_imu(imu_path)
    T_b_i = imu.T_b_i_array
    if not np.array_equal(T_b_i, np.eye(4)):      # cameras were read in the IMU frame
        cams = [dataclasses.replace(c, T_b_c=T_b_i @ c.T_b_c_array) for c in cams]
    try:
        return Rig(name=name, cameras=tuple(cams), imu=imu, camera_rate_hz=camera_rate_hz, mount=mount)
    except RigError as exc:
        raise RigError(f"{source}: {exc}") from None


def read_kalibr_timeshift(camchain_path) -> float:
    """``timeshift_cam_imu`` of cam0 in seconds (``t_imu = t_cam + shift``; 0 when absent)."""
    source = str(camchain_path)
    d = read_yaml_file(camchain_path)
    if not isinstance(d, dict) or not isinstance(d.get("cam0"), dict):
        raise field_error(source, "cam0", "missing field (expected cam0:, cam1:, ... sections)")
    v = d["cam0"].get("timeshift_cam_imu", 0.0)
    return field_number(v, source, "cam0.timeshift_cam_imu")


# ----------------------------------------------------------------------------- EuRoC sensor.yaml
