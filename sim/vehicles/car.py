"""A passenger car carrying the rig on a roof rack: body 4.4 x 1.76 m, cabin, four wheels.

:data:`CAR` holds its running gear, the one place these dimensions live: track 1.55 m, wheelbase
2.7 m, wheels of radius 0.32 m (a mid-size saloon). The motion model reads them through
``motion.wheelbase_m`` / ``motion.track_m`` (the ``urban-*`` scenarios set both to these values).

Geometry is placed from the rig, as for the cart: the cameras sit on a rack above the top of the
windscreen, the hood's front edge is :data:`HOOD_AHEAD_M` ahead of the front-most camera at
:data:`HOOD_TOP_M` and the roof ends :data:`ROOF_BELOW_CAMERAS_M` below the lowest camera. From a
camera 1.65 m high the hood's front edge is ``atan(0.75 / 1.4)`` = 28 deg below the horizon, outside
the vertical half field of view of the car rigs (23.5 deg for ``paper002``, 14.5 deg for
``kitti-like``), so forward-looking cameras do not see the car (tests/test_vehicles_car.py).
"""
from __future__ import annotations

from sim.vehicles.base import DARK, GREY, Vehicle, VehicleDims

CAR = VehicleDims(track_m=1.55, wheelbase_m=2.7, wheel_radius_m=0.32)
CAR_LENGTH_M = 4.4
CAR_HALF_WIDTH_M = 0.88
HOOD_AHEAD_M = 1.4          # hood front edge ahead of the front-most camera
HOOD_TOP_M = 0.9            # top of the lower body (hood, boot, sills)
SILL_M = 0.3                # bottom of the lower body
ROOF_BELOW_CAMERAS_M = 0.12
_PAINT = (0.55, 0.08, 0.08, 1.0)
_GLASS = (0.12, 0.15, 0.2, 1.0)


class Car(Vehicle):
    kind = "car"
    dims = CAR

    def footprint(self) -> tuple:
        x_front = self.cam_extent()[0]
        return x_front + HOOD_AHEAD_M - CAR_LENGTH_M / 2, CAR_LENGTH_M / 2, CAR_HALF_WIDTH_M

    def _add_body_geoms(self, body) -> None:
        x_front, _, z_low = self.cam_extent()
        xc = self.footprint()[0]                                 # footprint centre in b
        half_h = (HOOD_TOP_M - SILL_M) / 2
        self.geom(body, "body", "box", [CAR_LENGTH_M / 2, CAR_HALF_WIDTH_M, half_h],
                  [xc, 0.0, SILL_M + half_h], _PAINT)
        roof = z_low - ROOF_BELOW_CAMERAS_M
        x_rear = xc - CAR_LENGTH_M / 2 + 0.5                     # cabin ends 0.5 m before the boot lid
        x_screen = x_front - 0.05                                 # cabin front under the cameras
        if roof > HOOD_TOP_M and x_screen > x_rear:
            self.geom(body, "cabin", "box", [(x_screen - x_rear) / 2, CAR_HALF_WIDTH_M - 0.1,
                                             (roof - HOOD_TOP_M) / 2],
                      [(x_screen + x_rear) / 2, 0.0, (roof + HOOD_TOP_M) / 2], _GLASS)
        half_base = self.dims.wheelbase_m / 2
        self.wheels(body, (half_base, -half_base), xc, DARK, half_width=0.11)
        self.add_mast(body, roof, GREY)
