"""Preset rigs: ``cart27`` (seed 000), ``stereo27`` (ideal 27 cm pair), ``yutu-navcam`` (seed 001),
``paper002`` (seed 002, car roof) and ``kitti-like`` (KITTI odometry geometry, car roof).

Body frame ``b``: x forward, y left, z up, origin on the ground at the vehicle centre.
A forward-looking OpenCV camera has ``R_b_c = R_B_C_FORWARD``. The left camera c0 sits half a
baseline left of the mast point, ``t_b_c0 = p_mast + (0, B/2, 0)`` with ``B = |t_c0_c1|``, and the
right camera follows from the calibration, ``T_b_c1 = T_b_c0 @ T_c0_c1`` (near ``-B/2`` in y). The IMU sits on the
mast ``IMU_BELOW_CAMERAS_M`` below the cameras with axes aligned with ``b``.

The code is the source of truth; ``rigs/presets/<name>.yaml`` are written from it by
:func:`write_preset_yamls` (after changing a preset: ``python -c "from rigs.presets import
write_preset_yamls; write_preset_yamls()"``), and ``tests/test_rigs_presets_files.py`` checks that the files
are what it writes, byte for byte.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from rigs.errors import RigError
from rigs.geometry import R_from_opk_deg, make_T, rot_x
from rigs.imu_models import get_imu_model
from rigs.kalibr_io import is_kalibr_camchain, read_kalibr
from rigs.model import Camera, Rig
from rigs.overrides import apply_overrides
from rigs.rig_yaml import load_rig, save_rig

PRESET_DIR = Path(__file__).with_name("presets")
R_B_C_FORWARD = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
MAST_XYZ_CART = (0.3, 0.0, 1.2)      # m: 0.3 m forward of the vehicle centre, 1.2 m above ground
IMU_BELOW_CAMERAS_M = 0.2

# seed 000, Table 2 (CV standard, 4800x3200 images); distortion in OpenCV order (k1, k2, p1, p2, k3)
CART27_FULL = {
    "cam0": dict(fx=3362.10, fy=3362.10, cx=2406.70, cy=1601.75, dist=(0.0176, -0.0356, -0.0006, -0.0005, 0.0507)),
    "cam1": dict(fx=3366.02, fy=3366.02, cx=2429.80, cy=1604.78, dist=(0.0176, -0.0373, -0.0001, 0.0008, 0.0444)),
}
CART27_FULL_SIZE = (4800, 3200)
CART27_SCALE = 0.15                  # 4800x3200 -> 720x480, same field of view
CART27_OPK_DEG = (-0.01406, -0.75671, 0.80437)   # seed 000 Table 3, omega phi kappa (deg)
CART27_T_C0_C1 = (0.2857, 0.0005, -0.0041)       # seed 000 Table 3, metres


def scale_intrinsics(fx, fy, cx, cy, s):
    """Resample an image by ``s`` keeping the FOV, OpenCV pixel centres at integers:
    ``f' = s f``, ``c' = s (c + 0.5) - 0.5``. Normalised-coordinate distortion is unchanged."""
    return s * fx, s * fy, s * (cx + 0.5) - 0.5, s * (cy + 0.5) - 0.5


def mast_stereo_T_b_c(R_b_c0, T_c0_c1, mast_xyz):
    """Poses (T_b_c0, T_b_c1): c0 at ``mast_xyz + (0, B/2, 0)`` (B = |t_c0_c1|), c1 = c0 * T_c0_c1."""
    T_c0_c1 = np.asarray(T_c0_c1, dtype=float)
    B = np.linalg.norm(T_c0_c1[:3, 3])
    t_b_c0 = np.asarray(mast_xyz, dtype=float) + np.array([0.0, B / 2.0, 0.0])
    T_b_c0 = make_T(R_b_c0, t_b_c0)
    return T_b_c0, T_b_c0 @ T_c0_c1


def _mast_imu(imu_name, mast_xyz):
    """Named IMU model mounted ``IMU_BELOW_CAMERAS_M`` below the mast point, axes along ``b``."""
    x, y, z = mast_xyz
    T_b_i = make_T(np.eye(3), (x, y, z - IMU_BELOW_CAMERAS_M))
    return dataclasses.replace(get_imu_model(imu_name), T_b_i=T_b_i)


def _stereo_rig(name, intr0, intr1, size, T_c0_c1, R_b_c0, mast_xyz, rate_hz, imu_name, mount):
    T_b_c0, T_b_c1 = mast_stereo_T_b_c(R_b_c0, T_c0_c1, mast_xyz)
    w, h = size
    cams = (Camera("cam0", w, h, T_b_c=T_b_c0, **intr0), Camera("cam1", w, h, T_b_c=T_b_c1, **intr1))
    imu = _mast_imu(imu_name, mast_xyz)
    return Rig(name=name, cameras=cams, imu=imu, camera_rate_hz=rate_hz, wheels=None, mount=mount)


def build_cart27() -> Rig:
    """Seed 000's camping-cart rig, images scaled by ``CART27_SCALE`` = 0.15 (4800x3200 -> 720x480).

    Intrinsics and distortion from Table 2 (listed there as k1, k2, k3, p1, p2; stored here in
    OpenCV order k1, k2, p1, p2, k3). Relative orientation from Table 3, taken as
    ``R_c0_c1 = R_from_opk_deg(omega, phi, kappa)`` and ``t_c0_c1 = (0.2857, 0.0005, -0.0041)`` m
    expressed in the OpenCV left-camera frame (assumption: the paper does not name the frame;
    x along the baseline fits the stated baseline 0.2857 m). Mast 1.2 m high, 0.3 m forward, 10 Hz.
    """
    intr = {}
    for cam, p in CART27_FULL.items():
        fx, fy, cx, cy = scale_intrinsics(p["fx"], p["fy"], p["cx"], p["cy"], CART27_SCALE)
        intr[cam] = dict(fx=fx, fy=fy, cx=cx, cy=cy, dist=p["dist"])
    size = tuple(int(round(CART27_SCALE * n)) for n in CART27_FULL_SIZE)
    T_c0_c1 = make_T(R_from_opk_deg(*CART27_OPK_DEG), CART27_T_C0_C1)
    return _stereo_rig("cart27", intr["cam0"], intr["cam1"], size, T_c0_c1, R_B_C_FORWARD,
                       MAST_XYZ_CART, 10.0, "euroc-adis16448", "cart mast")


def build_stereo27() -> Rig:
    """Ideal pair: 752x480, f = 458 px, c = image centre, no distortion, parallel, 0.27 m, 20 Hz."""
    intr = dict(fx=458.0, fy=458.0, cx=375.5, cy=239.5, dist=(0.0,) * 5)
    T_c0_c1 = make_T(np.eye(3), (0.27, 0.0, 0.0))
    return _stereo_rig("stereo27", intr, intr, (752, 480), T_c0_c1, R_B_C_FORWARD,
                       MAST_XYZ_CART, 20.0, "euroc-adis16448", "cart mast")


def build_yutu_navcam() -> Rig:
    """Seed 001's Yutu Navcam: f = 1189 px, 1024x1024 (2 atan(512/1189) = 46.6 deg FOV), B = 0.27 m,
    parallel, on a pan-tilt mast 1.5 m above ground tilted down 20 deg; 1 Hz (images at waypoints).
    Tilting down rotates the optical axis toward camera +y: ``R_b_c = R_B_C_FORWARD @ rot_x(-20 deg)``.
    """
    intr = dict(fx=1189.0, fy=1189.0, cx=511.5, cy=511.5, dist=(0.0,) * 5)
    T_c0_c1 = make_T(np.eye(3), (0.27, 0.0, 0.0))
    R_b_c0 = R_B_C_FORWARD @ rot_x(np.radians(-20.0))
    return _stereo_rig("yutu-navcam", intr, intr, (1024, 1024), T_c0_c1, R_b_c0,
                       (0.3, 0.0, 1.5), 1.0, "euroc-adis16448", "pan-tilt mast")


MAST_XYZ_CAR = (0.8, 0.0, 1.65)      # m: roof rack above the windscreen top (sim.vehicles.car)
PAPER002_SIZE = (640, 400)           # 1920x1200 (BFLY-U3-23S6C) binned by 3
PAPER002_F = 460.0                   # seed 002 eq. 27's virtual focal length
PAPER002_BASELINE_M = 0.5
KITTI_SIZE = (1241, 376)             # KITTI odometry sequences 00-02, camera P0
KITTI_INTR = dict(fx=718.856, fy=718.856, cx=607.1928, cy=185.2157, dist=(0.0,) * 5)
KITTI_BASELINE_M = 0.537


def build_paper002() -> Rig:
    """Seed 002's sensors (Section 5.1) on a car roof: the monocular 10 Hz camera is ``cam0``; a parallel
    ``cam1`` 0.5 m to its right (not in the paper) lets the stereo estimators run on the same data.

    The paper gives the camera model (BFLY-U3-23S6C-C, 1920x1200) but no lens: the images are
    binned by 3 to 640x400 with f = 460 px (the virtual focal length of eq. 27), 69.6 deg x 47.0 deg
    field of view, principal point at the image centre, no distortion. IMU: ``xsens-mti10``, the paper's
    Xsens MTi 10 from its datasheet, 200 Hz (Table 1's IMU values are the estimator's configuration, not the
    sensor's noise: :mod:`rigs.imu_models`). Mount point 1.65 m above ground, 0.8 m forward of the car's centre.
    """
    w, h = PAPER002_SIZE
    intr = dict(fx=PAPER002_F, fy=PAPER002_F, cx=(w - 1) / 2, cy=(h - 1) / 2, dist=(0.0,) * 5)
    T_c0_c1 = make_T(np.eye(3), (PAPER002_BASELINE_M, 0.0, 0.0))
    return _stereo_rig("paper002", intr, intr, PAPER002_SIZE, T_c0_c1, R_B_C_FORWARD,
                       MAST_XYZ_CAR, 10.0, "xsens-mti10", "car roof")


def build_kitti_like() -> Rig:
    """KITTI odometry geometry: 1241x376, fx = fy = 718.856, (cx, cy) = (607.1928, 185.2157) (sequence 00
    P0), parallel pair, baseline 0.537 m, 10 Hz, 1.65 m above ground. KITTI's OXTS IMU is not part of the
    odometry benchmark; the rig carries the ``euroc-adis16448`` model so IMU data exist."""
    T_c0_c1 = make_T(np.eye(3), (KITTI_BASELINE_M, 0.0, 0.0))
    return _stereo_rig("kitti-like", KITTI_INTR, KITTI_INTR, KITTI_SIZE, T_c0_c1, R_B_C_FORWARD,
                       MAST_XYZ_CAR, 10.0, "euroc-adis16448", "car roof")


FISHEYE150_SIZE = (640, 480)
FISHEYE150_F = 315.0                 # px: the image corners see rays 75 deg off axis (150 deg diagonal FOV)
FISHEYE150_K = (-0.01, 0.04, -0.04, 0.008)   # equidistant k1..k4, of the order of tracking-camera lenses
FISHEYE150_BASELINE_M = 0.12


def build_fisheye150() -> Rig:
    """Two parallel equidistant (Kannala-Brandt) fisheye cameras, 640x480, f = 315 px, k1..k4 =
    ``FISHEYE150_K``: the image corners see rays 75 deg off axis (150 deg diagonal field of view;
    117 deg x 87 deg horizontally x vertically), baseline 0.12 m, 20 Hz, on the cart mast. Rendered
    through a 1892x1420 pinhole canvas (:mod:`sim.distortion`)."""
    w, h = FISHEYE150_SIZE
    intr = dict(fx=FISHEYE150_F, fy=FISHEYE150_F, cx=(w - 1) / 2, cy=(h - 1) / 2, dist=FISHEYE150_K,
                dist_model="equidistant")
    T_c0_c1 = make_T(np.eye(3), (FISHEYE150_BASELINE_M, 0.0, 0.0))
    return _stereo_rig("fisheye150", intr, intr, FISHEYE150_SIZE, T_c0_c1, R_B_C_FORWARD,
                       MAST_XYZ_CART, 20.0, "euroc-adis16448", "cart mast")


_BUILDERS = {"cart27": build_cart27, "fisheye150": build_fisheye150, "stereo27": build_stereo27, "yutu-navcam": build_yutu_navcam,
             "paper002": build_paper002, "kitti-like": build_kitti_like}
_HEADERS = {
    "cart27": "Seed 000 camping-cart rig (Tables 2-3), images scaled by s = 0.15: 4800x3200 -> 720x480,\n"
              "f' = s f, c' = s (c + 0.5) - 0.5 (same field of view). Written by rigs.presets; do not edit.",
    "stereo27": "Ideal parallel 0.27 m stereo pair, 752x480, f = 458 px. Written by rigs.presets; do not edit.",
    "yutu-navcam": "Seed 001 Yutu Navcam, f = 1189 px, 1024x1024, B = 0.27 m, mast 1.5 m tilted down 20 deg.\n"
                   "Written by rigs.presets; do not edit.",
    "paper002": "Seed 002 monocular 10 Hz camera (640x400, f = 460 px) as cam0 of a parallel 0.5 m pair, Xsens MTi 10\n"
                "IMU (datasheet densities) at 200 Hz, car roof 1.65 m. Written by rigs.presets; do not edit.",
    "fisheye150": "Two parallel equidistant (Kannala-Brandt) fisheye cameras, 640x480, f = 315 px, 150 deg diagonal\n"
                  "field of view, baseline 0.12 m, 20 Hz. Written by rigs.presets; do not edit.",
    "kitti-like": "KITTI odometry geometry: 1241x376, f = 718.856 px, baseline 0.537 m, 10 Hz, car roof 1.65 m.\n"
                  "Written by rigs.presets; do not edit.",
}


def rig_names() -> list[str]:
    """Sorted preset names accepted by :func:`get_rig`."""
    return sorted(_BUILDERS)


def get_rig(name: str, overrides=()) -> Rig:
    """Preset ``name`` (or a path to a rig ``.yaml`` file, ours or a Kalibr ``camchain-imucam.yaml``, see
    :func:`rigs.kalibr_io.read_kalibr`), with ``key=value`` overrides applied."""
    if name in _BUILDERS:
        rig = _BUILDERS[name]()
    elif isinstance(name, (str, Path)) and str(name).endswith((".yaml", ".yml")):
        rig = read_kalibr(name, name=Path(name).stem) if is_kalibr_camchain(name) else load_rig(name)
    else:
        raise RigError(f"rig {name!r}: unknown preset; valid names: {', '.join(rig_names())} "
                       f"(or a path to a .yaml file)")
    return apply_overrides(rig, overrides) if overrides else rig


def write_preset_yamls(folder=PRESET_DIR) -> list[Path]:
    """Write every preset to ``folder/<name>.yaml``; returns the paths."""
    paths = []
    for name in rig_names():
        path = Path(folder) / f"{name}.yaml"
        save_rig(_BUILDERS[name](), path, header=_HEADERS[name])
        paths.append(path)
    return paths
