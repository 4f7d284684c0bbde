"""A hand-held rig: no wheels, a grip below the cameras. For replayed motion (``generate --motion``).

Body frame ``b`` is the rig's own (the poses replayed are of ``b``, or of the IMU or ``cam0``); the grip
hangs :data:`GRIP_BELOW_M` below and :data:`GRIP_BEHIND_M` behind the rearmost camera, so forward-looking
cameras do not see it. It has no running gear (``dims = None``): a rig with wheel encoders is refused.
"""
from __future__ import annotations

import numpy as np

from sim.vehicles.base import DARK, GREY, Vehicle

GRIP_BELOW_M = 0.06
GRIP_BEHIND_M = 0.06
GRIP_LENGTH_M = 0.14


class Handheld(Vehicle):
    kind = "handheld"
    dims = None

    def footprint(self) -> tuple:
        """A 0.3 m square around the cameras (no ground contact; used for the actor clearance check)."""
        x_front, x_back, _ = self.cam_extent()
        return (x_front + x_back) / 2, 0.15, 0.15

    def _add_body_geoms(self, body) -> None:
        _, x_back, z_low = self.cam_extent()
        x, z_top = x_back - GRIP_BEHIND_M, z_low - GRIP_BELOW_M
        self.add_bar(body, x, z_top)
        self.geom(body, "grip", "cylinder", [0.018, GRIP_LENGTH_M / 2], [x, 0.0, z_top - GRIP_LENGTH_M / 2], DARK)

    def add_bar(self, body, x: float, z: float) -> None:

        p_b = np.array([c.T_b_c_array[:3, 3] for c in self.rig.cameras])
        half = max(0.05, float(np.ptp(p_b[:, 1])) / 2 + 0.03)
        self.geom(body, "bar", "box", [0.015, half, 0.012], [x, float(p_b[:, 1].mean()), z], GREY)
