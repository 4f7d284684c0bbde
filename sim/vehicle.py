"""The vehicle in the MuJoCo world: a mocap body with visual geoms, the rig's cameras and IMU site.

Body frame ``b`` (ARCHITECTURE.md): x forward, y left, z up, origin on the ground at the centre
of the footprint. The mocap body's pose is ``T_w_b`` (set every frame, no physics). Geometry is
placed from the rig: the mast rises just *behind* the cameras to just *below* them, the bed /
chassis ends behind the front-most camera and far below it, so forward-looking cameras do not see
the vehicle (checked by tests/test_render_consistency.py). All vehicle geoms are named ``vehicle/...``,
in geom group :data:`VEHICLE_GROUP`, with ``contype = conaffinity = 0`` (visual only).
"""
from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before the first mujoco import (headless)

from dataclasses import dataclass

import mujoco  # noqa: E402
import numpy as np

from rigs.model import Rig
from sim import mjcam
from sim.errors import SimError

VEHICLE_KINDS = ("cart", "rover")
VEHICLE_GROUP = 4          # geom group of vehicle geoms (render option can hide it)
BODY_NAME = "vehicle"
IMU_SITE = "vehicle/imu"


def camera_name(cam_name: str) -> str:
    """MuJoCo camera name of rig camera ``cam_name``."""
    return f"vehicle/cam/{cam_name}"


@dataclass(frozen=True)
class VehicleHandles:
    """Names of the vehicle's MuJoCo elements (resolve ids on the compiled model)."""

    body: str
    camera_names: tuple      # one per rig camera, same order
    imu_site: str
    kind: str


_BOX, _CYL = mujoco.mjtGeom.mjGEOM_BOX, mujoco.mjtGeom.mjGEOM_CYLINDER
_GREY = [0.35, 0.35, 0.38, 1.0]
_DARK = [0.08, 0.08, 0.08, 1.0]
_GREEN = [0.15, 0.35, 0.2, 1.0]
_GOLD = [0.75, 0.6, 0.2, 1.0]
_QUAT_Y_AXIS = [np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0]   # cylinder axis z -> y (wheels)


def _geom(body, name, gtype, size, pos, rgba, quat=(1.0, 0.0, 0.0, 0.0)):
    body.add_geom(name=f"vehicle/{name}", type=gtype, size=list(size) + [0.0] * (3 - len(size)),
                  pos=[float(x) for x in pos], quat=list(quat), rgba=rgba,
                  contype=0, conaffinity=0, group=VEHICLE_GROUP)


def _cam_extent(rig: Rig) -> tuple:
    """(x_front, x_back, z_low) of the cameras' centres in ``b`` (metres)."""
    p_b = np.array([c.T_b_c_array[:3, 3] for c in rig.cameras])
    return float(p_b[:, 0].max()), float(p_b[:, 0].min()), float(p_b[:, 2].min())


def _add_mast(body, rig: Rig, bed_top: float, rgba) -> None:
    """Vertical mast ending 6 cm below and 8 cm behind the rearmost camera, plus a crossbar."""
    _, x_back, z_low = _cam_extent(rig)
    p_b = np.array([c.T_b_c_array[:3, 3] for c in rig.cameras])
    y_mid = float(p_b[:, 1].mean())
    half_span = max(0.05, float(np.ptp(p_b[:, 1])) / 2 + 0.03)
    x_mast, z_top = x_back - 0.08, z_low - 0.06
    if z_top > bed_top:
        _geom(body, "mast", _CYL, [0.02, (z_top - bed_top) / 2],
              [x_mast, y_mid, (z_top + bed_top) / 2], rgba)
    _geom(body, "crossbar", _BOX, [0.02, half_span, 0.015], [x_mast, y_mid, z_top], rgba)


def _add_cart(body, rig: Rig) -> None:
    """Camping cart: bed 0.9 x 0.5 m (top 0.45 m), four wheels, push handle at the rear."""
    x_front, _, _ = _cam_extent(rig)
    xc = min(0.0, x_front - 0.55)                  # bed centre: front edge 10 cm behind cameras
    bed_top, r = 0.45, 0.12
    _geom(body, "bed", _BOX, [0.45, 0.25, 0.1], [xc, 0.0, bed_top - 0.1], _GREEN)
    for i, (dx, dy) in enumerate([(0.3, 0.28), (0.3, -0.28), (-0.3, 0.28), (-0.3, -0.28)]):
        _geom(body, f"wheel{i}", _CYL, [r, 0.03], [xc + dx, dy, r], _DARK, _QUAT_Y_AXIS)
    _geom(body, "handle_bar", _CYL, [0.015, 0.25], [xc - 0.75, 0.0, 0.85], _GREY, _QUAT_Y_AXIS)
    for s in (1, -1):
        _geom(body, f"handle_arm{'lr'[s < 0]}", _BOX, [0.17, 0.012, 0.012],
              [xc - 0.6, 0.24 * s, 0.65], _GREY, [np.cos(-0.5), 0.0, np.sin(-0.5), 0.0])
    _add_mast(body, rig, bed_top, _GREY)


def _add_rover(body, rig: Rig) -> None:
    """Placeholder rover: gold chassis 1.4 x 1.0 m (top 0.75 m), six wheels, a mast."""
    x_front, _, _ = _cam_extent(rig)
    xc = min(0.0, x_front - 0.8)
    top, r = 0.75, 0.2
    _geom(body, "chassis", _BOX, [0.7, 0.5, 0.2], [xc, 0.0, top - 0.2], _GOLD)
    for i, dx in enumerate((0.5, 0.0, -0.5)):
        for s in (1, -1):
            _geom(body, f"wheel{i}{'lr'[s < 0]}", _CYL, [r, 0.06], [xc + dx, 0.58 * s, r],
                  _GREY, _QUAT_Y_AXIS)
    _add_mast(body, rig, top, _GREY)


def add_vehicle(spec, rig: Rig, kind: str = "cart") -> VehicleHandles:
    """Add the mocap body ``vehicle``, its geoms, the rig's cameras (exact K) and the IMU site."""
    if kind not in VEHICLE_KINDS:
        raise SimError(f"vehicle: unknown kind {kind!r}; valid: {', '.join(VEHICLE_KINDS)}")
    body = spec.worldbody.add_body(name=BODY_NAME, mocap=True)
    (_add_cart if kind == "cart" else _add_rover)(body, rig)
    names = []
    for cam in rig.cameras:
        pos, quat = mjcam.pos_quat_from_T(mjcam.T_b_mjcam(cam.T_b_c_array))
        mj_cam = body.add_camera(name=camera_name(cam.name), pos=pos, quat=quat)
        mjcam.apply_intrinsics(mj_cam, cam)
        names.append(camera_name(cam.name))
    pos, quat = mjcam.pos_quat_from_T(rig.imu.T_b_i_array)
    body.add_site(name=IMU_SITE, pos=pos, quat=quat, size=[0.01, 0.01, 0.01], group=VEHICLE_GROUP)
    return VehicleHandles(body=BODY_NAME, camera_names=tuple(names), imu_site=IMU_SITE, kind=kind)
