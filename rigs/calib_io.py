"""Calibration files of other tools: EuRoC sensor.yaml, KITTI calib.txt (Kalibr's files: :mod:`rigs.kalibr_io`),
and the conventions at this boundary.

Frame conventions at this boundary (``T_a_b`` maps points of b into a):

- Kalibr: ``T_cam_imu`` = ``T_c_i`` (OpenVINS' ``T_imu_cam`` = ``T_i_c`` is read too);
  ``T_cn_cnm1`` = ``T_c1_c0`` (camera n from camera n-1).
  Distortion ``radtan`` ``[k1, k2, r1, r2]`` = OpenCV ``(k1, k2, p1, p2)``. Kalibr has no ``k3``: a
  rig with ``k3 != 0`` cannot be expressed, the writer drops it and says so in a comment at the top
  of the file (our reader still accepts a fifth value, as older files of ours carry it).
  Distortion ``equidistant`` ``[k1, k2, k3, k4]`` (Kalibr ``pinhole-equi``) = ``cv2.fisheye``'s
  ``(k1, k2, k3, k4)`` = our ``dist_model: equidistant``; exact both ways.
  ``imu.yaml``'s ``T_i_b`` maps the vehicle body into the IMU frame (``inv(T_b_i)``); read back, the
  body frame is that frame (``T_b_c = inv(T_i_b) @ inv(T_cam_imu)``), the IMU frame without ``T_i_b``.
  ``timeshift_cam_imu`` [s]: ``t_imu = t_cam + shift`` (the convention of our ``imu_clock.time_offset_ms``).
- EuRoC ``sensor.yaml``: ``T_BS`` = ``T_B_S`` (sensor S into body B; in EuRoC B is the IMU frame).
  ``distortion_model: radial-tangential`` or ``equidistant`` (4 coefficients, as TUM-VI's EuRoC-layout files).
  Real files start with OpenCV's ``%YAML:1.0`` line, which the reader skips.
- KITTI odometry ``calib.txt``: rectified ``P_k = K [I | t_k]`` (3x4, row-major), camera 0 the
  reference, ``P1[0,3] = -fx * baseline``. It has no distortion at all (neither radtan nor
  equidistant): it describes rectified pinhole images only.

All writers are atomic (temp file + ``os.replace``); readers raise one-line RigErrors naming
the file and the field.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from rigs.atomic_io import atomic_write_text
from rigs.config_io import dump_yaml, read_yaml_file
from rigs.errors import RigError
from rigs.imu_models import get_imu_model
from rigs.model import Camera, Imu, Rig, as_matrix4
from rigs.calib_fields import check_keys, field_error, field_floats, field_int, field_number

ORTHO_TOL = 1e-4   # calibration files print ~9-12 digits; re-orthonormalise rotations within this


def _rows(T) -> list:
    return [[float(x) for x in row] for row in np.asarray(T, dtype=float)]


def _opencv_dist(values) -> tuple:
    """4 or 5 coefficients (k1, k2, p1, p2[, k3]) -> OpenCV 5-tuple."""
    d = tuple(float(v) for v in values)
    return d + (0.0,) * (5 - len(d))


def _file_dist(dist) -> list:
    """OpenCV 5-tuple -> list of 4, plus k3 only if non-zero (an equidistant 4-tuple as it is)."""
    return [float(x) for x in (dist if len(dist) == 5 and dist[4] != 0.0 else dist[:4])]


def _radtan_k3(cam: Camera) -> float:
    """The radtan ``k3`` of ``cam`` (0 for an equidistant camera, whose 4 coefficients every format holds)."""
    return 0.0 if cam.is_fisheye else cam.dist[4]


def _rigid(rows, source, path) -> tuple:
    """4x4 nested list from a file -> validated rigid transform; rotations within ORTHO_TOL of
    orthonormal (printed with finite digits, as in EuRoC's T_BS) are projected onto SO(3)."""
    T = np.asarray(rows, dtype=float)
    U, _, Vt = np.linalg.svd(T[:3, :3])
    R = U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
    if 1e-9 < np.max(np.abs(R - T[:3, :3])) < ORTHO_TOL:
        T[:3, :3] = R
    try:
        return as_matrix4(T, path)
    except RigError as exc:
        raise RigError(f"{source}: {exc}") from None


def _resolution(value, source, path) -> tuple[int, int]:
    """``[width, height]`` -> two positive ints."""
    wh = field_floats(value, source, path, (2,))
    return field_int(wh[0], source, f"{path}[0]"), field_int(wh[1], source, f"{path}[1]")


def _matrix_field(value, source, path) -> tuple:
    if not isinstance(value, (list, tuple)) or len(value) != 4:
        raise field_error(source, path, f"expected 4 rows of 4 numbers, got {value!r}")
    return _rigid([field_floats(r, source, f"{path}[{i}]", (4,)) for i, r in enumerate(value)], source, path)


# ----------------------------------------------------------------------------- shared by the writers


def int_if_integral(x) -> float | int:
    """``10.0`` -> ``10`` (real EuRoC and Kalibr files write integral rates as integers), else the float."""
    x = float(x)
    return int(x) if x.is_integer() else x


def k3_corner_error_px(cam: Camera) -> float:
    """Largest pixel error over the 4 image corners when ``cam`` is modelled without its ``k3``: each
    corner is undistorted with the full model and re-distorted with ``(k1, k2, p1, p2)`` alone."""
    corners = np.array([[0, 0], [cam.width - 1, 0], [0, cam.height - 1], [cam.width - 1, cam.height - 1]],
                       dtype=float).reshape(-1, 1, 2)
    xy = cv2.undistortPoints(corners, cam.K, cam.dist_coeffs).reshape(-1, 2)
    rays = np.column_stack([xy, np.ones(len(xy))])
    four = np.array(tuple(cam.dist[:4]) + (0.0,))
    back, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), cam.K, four)
    return float(np.max(np.linalg.norm(back.reshape(-1, 2) - corners.reshape(-1, 2), axis=1)))


def dropped_k3_note(cam: Camera, label: str) -> str:
    """``"cam0: k3 = 0.0507 dropped (up to 8.0 px in the image corners)"``, or "" when ``k3 = 0``."""
    if _radtan_k3(cam) == 0.0:
        return ""
    return f"{label}: k3 = {cam.dist[4]!r} dropped (up to {k3_corner_error_px(cam):.1f} px in the image corners)"


def _T_BS_dict(T_B_S) -> dict:
    return {"cols": 4, "rows": 4, "data": [float(x) for x in np.asarray(T_B_S, dtype=float).reshape(16)]}


def write_euroc_camera_yaml(path, camera: Camera, T_B_S, rate_hz: float, four: bool = False) -> None:
    """EuRoC ``camK/sensor.yaml`` with ``T_BS`` = ``T_B_S`` (camera into body/IMU frame); an integral
    rate is written as an integer (``rate_hz: 20``, as real EuRoC). ``four``: list ``k1, k2, p1, p2``
    only, as real EuRoC does; a non-zero ``k3`` is then named in a comment at the top of the file
    (with the pixel error of leaving it out), else written as a fifth coefficient."""
    dist = list(camera.dist[:4]) if four else _file_dist(camera.dist)
    d = {"sensor_type": "camera", "comment": f"simulated {camera.name}", "T_BS": _T_BS_dict(T_B_S),
         "rate_hz": int_if_integral(rate_hz), "resolution": [camera.width, camera.height], "camera_model": "pinhole",
         "intrinsics": [camera.fx, camera.fy, camera.cx, camera.cy],
         "distortion_model": "equidistant" if camera.is_fisheye else "radial-tangential",
         "distortion_coefficients": [float(x) for x in dist]}
    header = "General sensor definitions (EuRoC layout)."
    if four and _radtan_k3(camera) != 0.0:
        header += ("\nNOT EXACT: EuRoC's radial-tangential has 4 coefficients; " + dropped_k3_note(camera, camera.name)
                   + ".\nrig.yaml at the dataset root holds the exact calibration (OpenCV k1 k2 p1 p2 k3).")
    atomic_write_text(path, "%YAML:1.0\n" + dump_yaml(d, header=header))


def write_euroc_imu_yaml(path, imu: Imu, T_B_S) -> None:
    """EuRoC ``imu0/sensor.yaml`` (Kalibr densities) with ``T_BS`` = ``T_B_S``."""
    d = {"sensor_type": "imu", "comment": f"simulated IMU ({imu.name})", "T_BS": _T_BS_dict(T_B_S),
         "rate_hz": int_if_integral(imu.rate_hz), "gyroscope_noise_density": imu.gyro_noise_density,
         "gyroscope_random_walk": imu.gyro_random_walk, "accelerometer_noise_density": imu.accel_noise_density,
         "accelerometer_random_walk": imu.accel_random_walk}
    atomic_write_text(path, "%YAML:1.0\n" + dump_yaml(d, header="Default imu sensor yaml file (EuRoC layout)."))


def _read_T_BS(d, source) -> tuple:
    check_keys(d, ("cols", "rows", "data"), (), source, "T_BS")
    if d["cols"] != 4 or d["rows"] != 4:
        raise field_error(source, "T_BS", f"expected rows: 4 and cols: 4, got {d['rows']!r}x{d['cols']!r}")
    data = field_floats(d["data"], source, "T_BS.data", (16,))
    return _rigid(np.reshape(data, (4, 4)), source, "T_BS")


def _read_sensor(path, sensor_type, required, optional) -> tuple[dict, str]:
    source = str(path)
    d = read_yaml_file(path)
    check_keys(d, required, optional, source, "")
    if d["sensor_type"] != sensor_type:
        raise field_error(source, "sensor_type", f"expected {sensor_type!r}, got {d['sensor_type']!r}")
    return d, source


def read_euroc_camera_yaml(path, name: str = "cam0") -> tuple[Camera, float]:
    """EuRoC camera ``sensor.yaml`` -> (Camera with ``T_b_c = T_BS``, rate_hz)."""
    d, src = _read_sensor(path, "camera", ("sensor_type", "T_BS", "rate_hz", "resolution", "camera_model",
                                           "intrinsics", "distortion_model", "distortion_coefficients"), ("comment",))
    if d["camera_model"] != "pinhole":
        raise field_error(src, "camera_model", f"only 'pinhole' is supported, got {d['camera_model']!r}")
    if d["distortion_model"] not in ("radial-tangential", "equidistant"):
        raise field_error(src, "distortion_model",
                          f"only 'radial-tangential' and 'equidistant' are supported, got {d['distortion_model']!r}")
    fisheye = d["distortion_model"] == "equidistant"
    fu, fv, cu, cv = field_floats(d["intrinsics"], src, "intrinsics", (4,))
    w, h = _resolution(d["resolution"], src, "resolution")
    coeffs = field_floats(d["distortion_coefficients"], src, "distortion_coefficients", (4,) if fisheye else (4, 5))
    cam = Camera(name=name, width=w, height=h, fx=fu, fy=fv, cx=cu, cy=cv,
                 dist=tuple(coeffs) if fisheye else _opencv_dist(coeffs),
                 dist_model="equidistant" if fisheye else "radtan", T_b_c=_read_T_BS(d["T_BS"], src))
    return cam, field_number(d["rate_hz"], src, "rate_hz", positive=True)


def read_euroc_imu_yaml(path, name: str = "euroc-imu") -> Imu:
    """EuRoC IMU ``sensor.yaml`` -> Imu with ``T_b_i = T_BS``."""
    keys = ("gyroscope_noise_density", "gyroscope_random_walk", "accelerometer_noise_density",
            "accelerometer_random_walk")
    d, src = _read_sensor(path, "imu", ("sensor_type", "T_BS", "rate_hz") + keys, ("comment",))
    v = {k: field_number(d[k], src, k, nonneg=True) for k in keys}
    return Imu(name=name, rate_hz=field_number(d["rate_hz"], src, "rate_hz", positive=True),
               accel_noise_density=v["accelerometer_noise_density"], gyro_noise_density=v["gyroscope_noise_density"],
               accel_random_walk=v["accelerometer_random_walk"], gyro_random_walk=v["gyroscope_random_walk"],
               T_b_i=_read_T_BS(d["T_BS"], src))


# ----------------------------------------------------------------------------- KITTI calib.txt
def _fmt_row(M) -> str:
    return " ".join(f"{x:.12e}" for x in np.asarray(M, dtype=float).reshape(-1))


def write_kitti_calib(path, P0, P1, Tr=None) -> None:
    """KITTI odometry ``calib.txt``: P0, P1, P2 = P0, P3 = P1 (3x4 row-major), optional ``Tr`` (3x4)."""
    P0, P1 = np.asarray(P0, dtype=float), np.asarray(P1, dtype=float)
    if P0.shape != (3, 4) or P1.shape != (3, 4):
        raise RigError(f"{path}: P0/P1: expected 3x4 projection matrices, got {P0.shape} and {P1.shape}")
    lines = [f"P{k}: {_fmt_row(P)}" for k, P in enumerate((P0, P1, P0, P1))]
    if Tr is not None:
        lines.append(f"Tr: {_fmt_row(np.asarray(Tr, dtype=float)[:3])}")
    atomic_write_text(path, "\n".join(lines) + "\n")


def parse_kitti_calib(path) -> dict:
    """``calib.txt`` -> {'P0': (3,4), ..., 'Tr': (3,4)} for every ``KEY: 12 numbers`` line."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RigError(f"{path}: cannot read file: {getattr(exc, 'strerror', None) or exc}") from None
    out = {}
    for n, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        key, _, rest = line.partition(":")
        try:
            vals = np.array([float(x) for x in rest.split()])
        except ValueError:
            raise RigError(f"{path}: line {n} ({key.strip()}): expected numbers, got {rest.strip()[:40]!r}") from None
        if len(vals) != 12 or not np.all(np.isfinite(vals)):
            raise RigError(f"{path}: line {n} ({key.strip()}): expected 12 finite numbers, got {len(vals)}")
        out[key.strip()] = vals.reshape(3, 4)
    for k in ("P0", "P1"):
        if k not in out:
            raise RigError(f"{path}: {k}: missing field (lines P0: .. P3:, optional Tr:)")
    return out


def read_kitti_calib(path, rate_hz: float = 10.0, width: int = 1241, height: int = 376,
                     name: str = "kitti") -> Rig:
    """Rectified pinhole stereo rig from ``calib.txt``: both cameras use K of P0, body = c0,
    parallel axes, ``baseline = (P0[0,3] - P1[0,3]) / P1[0,0]`` (= ``-P1[0,3]/fx`` when P0 has no
    translation, as in KITTI). The IMU is the ``ideal`` model at the body origin."""
    P = parse_kitti_calib(path)
    P0, P1 = P["P0"], P["P1"]
    fx, fy, cx, cy = P0[0, 0], P0[1, 1], P0[0, 2], P0[1, 2]
    B = (P0[0, 3] - P1[0, 3]) / P1[0, 0]
    if not B > 0:
        raise RigError(f"{path}: P1: baseline -P1[0,3]/P1[0,0] must be positive, got {B!r}")
    T_c0_c1 = np.eye(4)
    T_c0_c1[0, 3] = B
    try:
        cams = tuple(Camera(name=f"cam{k}", width=width, height=height, fx=fx, fy=fy, cx=cx, cy=cy, T_b_c=T)
                     for k, T in enumerate((np.eye(4), T_c0_c1)))
        return Rig(name=name, cameras=cams, imu=get_imu_model("ideal"), camera_rate_hz=rate_hz, mount="kitti")
    except RigError as exc:
        raise RigError(f"{path}: {exc}") from None


__all__ = ["int_if_integral", "k3_corner_error_px", "dropped_k3_note", "write_euroc_camera_yaml",
           "write_euroc_imu_yaml", "read_euroc_camera_yaml", "read_euroc_imu_yaml", "write_kitti_calib",
           "read_kitti_calib", "parse_kitti_calib"]
