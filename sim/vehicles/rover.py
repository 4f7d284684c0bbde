"""A six-wheel lunar rover (Yutu-like): chassis 1.5 x 1.0 m, rocker wheels on three axles, a mast
carrying a pan-tilt head with the stereo pair.

:data:`ROVER` holds its running gear: wheel centres at ``+-0.58`` m (track 1.16 m), axles at
``+0.5, 0, -0.5`` m (wheelbase 1.0 m between the outer axles), wheels of radius 0.2 m.

Mast kinematics (CONVENTIONS.md, "Rovers and mounts"): the camera ``k`` pose on the body is
``T_b_c(pan, tilt) = T_b_mast @ R_z(pan) @ R_y(tilt) @ T_head_c[k]``; pan positive to the left
about body z, tilt positive nose-down about the head's y. :class:`MastHead` recovers ``T_b_mast``
(the midpoint of the camera centres, axes along ``b``), the rig's nominal tilt and ``T_head_c``
from a rig whose cameras are mounted at pan 0 (the ``yutu-navcam`` preset: head at (0.3, 0, 1.5) m,
tilt 20 deg). :meth:`MastHead.set_pointing` moves the MuJoCo cameras of a compiled world to a
pointing (the camera pose is set per capture; the head geometry is static).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim import mjcam
from sim.errors import SimError
from sim.vehicles.base import DARK, GREY, Vehicle, VehicleDims

ROVER = VehicleDims(track_m=1.16, wheelbase_m=1.0, wheel_radius_m=0.2)
ROVER_LENGTH_M = 1.5
ROVER_WIDTH_M = 1.0
_GOLD = (0.75, 0.6, 0.2, 1.0)
_TOP = 0.75                  # chassis top (m)
_BOTTOM = 0.42               # chassis bottom (m), above the wheels' tops


def _rot_y(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rot_z(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def _T(R, t=(0.0, 0.0, 0.0)):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


@dataclass(frozen=True)
class MastHead:
    """Pan-tilt head: ``T_b_mast`` (4,4), ``T_head_c`` (K,4,4) per rig camera, ``tilt0_rad`` the rig's
    nominal tilt (its ``T_b_c`` is the pointing pan 0, tilt ``tilt0_rad``)."""

    T_b_mast: np.ndarray
    T_head_c: np.ndarray
    tilt0_rad: float

    @classmethod
    def from_rig(cls, rig) -> "MastHead":
        T_b_c = np.array([c.T_b_c_array for c in rig.cameras])
        z_b = T_b_c[0, :3, 2]                                    # optical axis of cam0 in b
        if abs(z_b[1]) > 1e-6:
            raise SimError(f"rover mast: rig {rig.name!r} cam0 must look along the body x-z plane at pan 0, "
                           f"its optical axis is {np.round(z_b, 4).tolist()}")
        tilt0 = float(np.arctan2(-z_b[2], z_b[0]))
        T_b_mast = _T(np.eye(3), T_b_c[:, :3, 3].mean(axis=0))
        T_mast_head0 = np.linalg.inv(T_b_mast @ _T(_rot_y(tilt0)))
        return cls(T_b_mast, np.einsum("ij,kjl->kil", T_mast_head0, T_b_c), tilt0)

    def T_b_c(self, k: int, pan_rad: float, tilt_rad: float) -> np.ndarray:
        """(4,4) pose of rig camera ``k`` on the body at the pointing (pan, tilt)."""
        return self.T_b_mast @ _T(_rot_z(pan_rad) @ _rot_y(tilt_rad)) @ self.T_head_c[k]

    def set_pointing(self, world, pan_rad: float, tilt_rad: float) -> None:
        """Place the cameras of compiled ``world`` (built with this rig on a rover) at (pan, tilt);
        takes effect at the next ``world.set_vehicle_pose`` (every render calls it)."""
        for k, cid in enumerate(world.camera_ids):
            pos, quat = mjcam.pos_quat_from_T(mjcam.T_b_mjcam(self.T_b_c(k, pan_rad, tilt_rad)))
            world.model.cam_pos[cid], world.model.cam_quat[cid] = pos, quat


class Rover(Vehicle):
    kind = "rover"
    dims = ROVER

    def _add_body_geoms(self, body) -> None:
        head = MastHead.from_rig(self.rig)
        xm, ym, zm = head.T_b_mast[:3, 3]
        half_h = (_TOP - _BOTTOM) / 2
        self.geom(body, "chassis", "box", [ROVER_LENGTH_M / 2, ROVER_WIDTH_M / 2 - 0.12, half_h],
                  [0.0, 0.0, _BOTTOM + half_h], _GOLD)
        for s in (1, -1):                                        # solar panels over the wheels
            self.geom(body, f"panel{'lr'[s < 0]}", "box", [0.6, 0.12, 0.01],
                      [-0.1, s * (ROVER_WIDTH_M / 2 - 0.06), _TOP - 0.01], (0.1, 0.12, 0.3, 1.0))
        half_base = self.dims.wheelbase_m / 2
        self.wheels(body, (half_base, 0.0, -half_base), 0.0, DARK, half_width=0.07)
        x_mast = xm - 0.12                                       # just behind the head
        z_top = zm - 0.12
        if z_top > _TOP:
            self.geom(body, "mast", "cylinder", [0.03, (z_top - _TOP) / 2], [x_mast, ym, (z_top + _TOP) / 2], GREY)
        self.geom(body, "head", "box", [0.05, 0.2, 0.04], [x_mast, ym, z_top + 0.04], GREY)

    def _wheel_name(self, k: int, dx: float, side: int) -> str:
        return f"wheel{k // 2}{'lr'[side < 0]}"
