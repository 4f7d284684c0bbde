"""A vehicle as a part that owns its MJCF subtree (dm_control composer's entity as the model).

A :class:`Vehicle` adds itself to a ``mujoco.MjSpec`` under its own name scope (mocap body ``<name>``,
every element named ``<name>/...``; the ego vehicle's name is ``vehicle``) and returns its
:class:`VehicleHandles`; resolve ids on the compiled model. Body frame ``b`` (ARCHITECTURE.md): x forward, y left, z up, origin on the ground
at the centre of the footprint. The mocap body's pose is ``T_w_b`` (set every frame, no physics).

A subclass sets ``kind`` and ``dims`` (its :class:`VehicleDims`, the one place its dimensions live:
the MJCF body, the motion model's ground attitude and the wheel odometry all read them) and
implements :meth:`Vehicle._add_body_geoms`. Geometry is placed from the rig: the mast rises just
*behind* the cameras to just *below* them, the bed / chassis ends behind the front-most camera and
far below it, so forward-looking cameras do not see the vehicle (tests/test_render_consistency.py).
All vehicle geoms are visual only (``contype = conaffinity = 0``), in geom group :data:`VEHICLE_GROUP`.
"""
from __future__ import annotations

import math
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before the first mujoco import (headless)

from dataclasses import dataclass

import numpy as np

from rigs.model import Rig
from sim import mjcam
from sim.errors import SimError

VEHICLE_GROUP = 4          # geom group of vehicle geoms (render option can hide it)
BODY_NAME = "vehicle"      # the ego vehicle's name (its name scope is "vehicle/")
IMU_SITE = BODY_NAME + "/imu"
QUAT_Y_AXIS = (math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0)   # cylinder axis z -> y (wheels)
GREY = (0.35, 0.35, 0.38, 1.0)
DARK = (0.08, 0.08, 0.08, 1.0)


def camera_name(cam_name: str, vehicle: str = BODY_NAME) -> str:
    """MuJoCo camera name of rig camera ``cam_name`` on vehicle ``vehicle``."""
    return f"{vehicle}/cam/{cam_name}"


@dataclass(frozen=True)
class VehicleDims:
    """A wheeled vehicle's running gear (m): ``track_m`` between left and right wheel centres,
    ``wheelbase_m`` between front and rear axles, ``wheel_radius_m``."""

    track_m: float
    wheelbase_m: float
    wheel_radius_m: float

    def __post_init__(self):
        for f in ("track_m", "wheelbase_m", "wheel_radius_m"):
            v = getattr(self, f)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise SimError(f"vehicle dims.{f}: must be a positive finite number, got {v!r}")


@dataclass(frozen=True)
class VehicleHandles:
    """Names of the vehicle's MuJoCo elements (resolve ids on the compiled model)."""

    body: str
    camera_names: tuple      # one per rig camera, same order
    imu_site: str
    kind: str


class Vehicle:
    """Base of the vehicles: adds body, geoms, the rig's cameras (exact K) and IMU site to a spec,
    all named in the scope ``name`` (``"vehicle"`` for the ego vehicle)."""

    kind: str = ""
    dims: VehicleDims = None

    def __init__(self, rig: Rig, name: str = BODY_NAME):
        if not isinstance(name, str) or not name or "/" in name:
            raise SimError(f"vehicle name: {name!r}; must be a non-empty string without '/'")
        self.rig, self.name = rig, name

    def add_to(self, spec) -> VehicleHandles:
        """Add the mocap body ``<name>`` with this vehicle's geoms, the rig's cameras and IMU site."""
        body = spec.worldbody.add_body(name=self.name, mocap=True)
        self._add_body_geoms(body)
        names = []
        for cam in self.rig.cameras:
            pos, quat = mjcam.pos_quat_from_T(mjcam.T_b_mjcam(cam.T_b_c_array))
            mj_cam = body.add_camera(name=camera_name(cam.name, self.name), pos=pos, quat=quat)
            mjcam.apply_intrinsics(mj_cam, cam)
            names.append(camera_name(cam.name, self.name))
        pos, quat = mjcam.pos_quat_from_T(self.rig.imu.T_b_i_array)
        imu_site = f"{self.name}/imu"
        body.add_site(name=imu_site, pos=pos, quat=quat, size=[0.01, 0.01, 0.01], group=VEHICLE_GROUP)
        return VehicleHandles(body=self.name, camera_names=tuple(names), imu_site=imu_site, kind=self.kind)

    def _add_body_geoms(self, body) -> None:
        raise NotImplementedError

    # ------------------------------------------------------------------ helpers for subclasses
    def geom(self, body, name, shape: str, size, pos, rgba, quat=(1.0, 0.0, 0.0, 0.0)) -> None:
        """Visual-only geom ``<vehicle name>/<name>``; ``shape`` "box" or "cylinder"."""
        import mujoco
        gtype = {"box": mujoco.mjtGeom.mjGEOM_BOX, "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER}[shape]
        body.add_geom(name=f"{self.name}/{name}", type=gtype, size=list(size) + [0.0] * (3 - len(size)),
                      pos=[float(x) for x in pos], quat=list(quat), rgba=list(rgba),
                      contype=0, conaffinity=0, group=VEHICLE_GROUP)

    def wheels(self, body, x_axles, x_centre: float, rgba, half_width: float) -> None:
        """One wheel pair per axle at ``x_centre + dx``: cylinders (axis y) of the dims' radius, centres at
        ``y = +-track/2`` (left first) and ``z = radius``; names from :meth:`_wheel_name`."""
        d = self.dims
        k = 0
        for dx in x_axles:
            for s in (1, -1):
                self.geom(body, self._wheel_name(k, dx, s), "cylinder", [d.wheel_radius_m, half_width],
                          [x_centre + dx, s * d.track_m / 2, d.wheel_radius_m], rgba, QUAT_Y_AXIS)
                k += 1

    def _wheel_name(self, k: int, dx: float, side: int) -> str:
        return f"wheel{k}"

    def footprint(self) -> tuple:
        """``(x_centre_b, half_length, half_width)`` (m) of the vehicle's ground footprint: by default the
        wheels' outline (wheelbase plus a wheel diameter long, track plus 0.2 m wide) centred on ``b``."""
        d = self.dims
        return 0.0, d.wheelbase_m / 2 + d.wheel_radius_m, d.track_m / 2 + 0.1

    def cam_extent(self) -> tuple:
        """(x_front, x_back, z_low) of the cameras' centres in ``b`` (metres)."""
        p_b = np.array([c.T_b_c_array[:3, 3] for c in self.rig.cameras])
        return float(p_b[:, 0].max()), float(p_b[:, 0].min()), float(p_b[:, 2].min())

    def add_mast(self, body, bed_top: float, rgba) -> None:
        """Vertical mast ending 6 cm below and 8 cm behind the rearmost camera, plus a crossbar."""
        _, x_back, z_low = self.cam_extent()
        p_b = np.array([c.T_b_c_array[:3, 3] for c in self.rig.cameras])
        y_mid = float(p_b[:, 1].mean())
        half_span = max(0.05, float(np.ptp(p_b[:, 1])) / 2 + 0.03)
        x_mast, z_top = x_back - 0.08, z_low - 0.06
        if z_top > bed_top:
            self.geom(body, "mast", "cylinder", [0.02, (z_top - bed_top) / 2],
                      [x_mast, y_mid, (z_top + bed_top) / 2], rgba)
        self.geom(body, "crossbar", "box", [0.02, half_span, 0.015], [x_mast, y_mid, z_top], rgba)
