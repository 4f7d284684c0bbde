"""The camping cart: bed 0.9 x 0.5 m (top 0.45 m), four wheels, a push handle at the rear, a mast.

:data:`CART` holds its running gear, the one place these dimensions live: wheel centres at
``+-0.28`` m (track 0.56 m), axles at ``+-0.3`` m from the bed centre (wheelbase 0.6 m), wheels of
radius 0.12 m. The MJCF body, the motion model's defaults (``sim.motion.MotionConfig``) and the
wheel odometry (:mod:`sim.sensors.wheels`) read them.
"""
from __future__ import annotations

import numpy as np

from sim.vehicles.base import DARK, GREY, Vehicle, VehicleDims

CART = VehicleDims(track_m=0.56, wheelbase_m=0.6, wheel_radius_m=0.12)
_GREEN = (0.15, 0.35, 0.2, 1.0)
_BED_TOP = 0.45


class Cart(Vehicle):
    kind = "cart"
    dims = CART

    def _add_body_geoms(self, body) -> None:
        x_front, _, _ = self.cam_extent()
        xc = min(0.0, x_front - 0.55)                  # bed centre: front edge 10 cm behind cameras
        self.geom(body, "bed", "box", [0.45, 0.25, 0.1], [xc, 0.0, _BED_TOP - 0.1], _GREEN)
        half_base = self.dims.wheelbase_m / 2
        self.wheels(body, (half_base, -half_base), xc, DARK, half_width=0.03)
        self.geom(body, "handle_bar", "cylinder", [0.015, 0.25], [xc - 0.75, 0.0, 0.85], GREY,
                  (np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0))
        for s in (1, -1):
            self.geom(body, f"handle_arm{'lr'[s < 0]}", "box", [0.17, 0.012, 0.012],
                      [xc - 0.6, 0.24 * s, 0.65], GREY, [np.cos(-0.5), 0.0, np.sin(-0.5), 0.0])
        self.add_mast(body, _BED_TOP, GREY)
