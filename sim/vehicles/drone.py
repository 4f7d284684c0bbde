"""A quadrotor carrying the rig: no wheels, a centre plate, four arms and rotor discs above the cameras.

Body frame ``b`` is the rig's own; the airframe sits :data:`FRAME_ABOVE_M` above the highest camera and
ends :data:`FRAME_BEHIND_M` behind the rearmost one, so forward-looking cameras do not see it. It has no
running gear (``dims = None``): a rig with wheel encoders is refused. For replayed motion
(``generate --motion``).
"""
from __future__ import annotations

import math

from sim.vehicles.base import DARK, GREY, Vehicle

ARM_M = 0.25               # centre to rotor axis
ROTOR_RADIUS_M = 0.12
FRAME_ABOVE_M = 0.08
FRAME_BEHIND_M = 0.05


class Drone(Vehicle):
    kind = "drone"
    dims = None

    def _centre(self):
        _, x_back, _ = self.cam_extent()
        z_high = float(max(c.T_b_c_array[2, 3] for c in self.rig.cameras))
        return x_back - FRAME_BEHIND_M - ARM_M - ROTOR_RADIUS_M, z_high + FRAME_ABOVE_M

    def footprint(self) -> tuple:
        x_c, _ = self._centre()
        half = ARM_M + ROTOR_RADIUS_M
        return x_c, half, half

    def _add_body_geoms(self, body) -> None:
        x_c, z = self._centre()
        self.geom(body, "plate", "box", [0.08, 0.08, 0.02], [x_c, 0.0, z], DARK)
        for k in range(4):
            a = math.pi / 4 + k * math.pi / 2
            c, s = math.cos(a), math.sin(a)
            q = (math.cos(a / 2), 0.0, 0.0, math.sin(a / 2))
            self.geom(body, f"arm{k}", "box", [ARM_M / 2, 0.01, 0.01], [x_c + c * ARM_M / 2, s * ARM_M / 2, z], GREY,
                      q)
            self.geom(body, f"rotor{k}", "cylinder", [ROTOR_RADIUS_M, 0.004],
                      [x_c + c * ARM_M, s * ARM_M, z + 0.02], (0.2, 0.2, 0.22, 0.6))
