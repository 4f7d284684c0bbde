"""Stop-and-go speed profile: a route with stops (``Route.stops_m``) driven as consecutive legs.

Each leg between two stops is a :class:`sim.motion.SpeedProfile` (rest, septic-smoothstep ramp up, cruise,
ramp down to rest); after every stop the vehicle rests ``Route.stop_dwell_s`` before the next leg. Speed,
acceleration and jerk are zero at each stop, so ``s(t)`` stays C3 across legs (the ramps are C3 at their
ends), and a leg too short to reach the cruise speed peaks lower (as :meth:`SpeedProfile.build` does).
The object has the attributes :class:`sim.motion.VehicleTrajectory` reads from a profile.
"""
from __future__ import annotations

import numpy as np

from sim.errors import SimError


class StopGoProfile:
    """Arc length ``s(t)`` over legs ``[0, stop_1], [stop_1, stop_2], ..., [stop_n, length]``."""

    def __init__(self, legs: list, offsets_m: np.ndarray):
        self.legs = legs
        self.offsets_m = np.asarray(offsets_m, float)
        durs = np.array([leg.duration for leg in legs])
        self.starts_s = np.r_[0.0, np.cumsum(durs)[:-1]]
        self.length_m = float(self.offsets_m[-1] + legs[-1].length_m)
        self.v_peak = float(max(leg.v_peak for leg in legs))
        self.t_rest0 = float(legs[0].t_rest0)
        self.t_rest1 = float(legs[-1].t_rest1)
        self.duration = float(durs.sum())

    @classmethod
    def build(cls, length_m: float, route, config, leg) -> "StopGoProfile":
        """Legs of ``route`` (``stops_m``, ``stop_dwell_s``, cruise speed, acceleration) with the rests and start
        speed of the motion ``config``; ``leg`` builds one leg with the arguments of
        :meth:`sim.motion.SpeedProfile.build` (the caller passes it, so this module does not import motion)."""
        stops = [float(s) for s in route.stops_m]
        if stops and stops[-1] >= length_m:
            raise SimError(f"route.stops_m: stop at {stops[-1]:.1f} m is beyond the route's {length_m:.1f} m")
        bounds = np.r_[0.0, stops, length_m]
        legs = []
        for i in range(len(bounds) - 1):
            first, last = i == 0, i == len(bounds) - 2
            legs.append(leg(float(bounds[i + 1] - bounds[i]), route.cruise_speed_mps, route.accel_mps2,
                            config.rest_before_s if first else float(route.stop_dwell_s),
                            config.rest_after_s if last else 0.0,
                            config.start_speed_mps if first else 0.0))
        return cls(legs, bounds[:-1])

    def __call__(self, t):
        """(N,) seconds from the start -> s, s', s'', s''' (N,) each."""
        t = np.asarray(t, dtype=float)
        k = np.clip(np.searchsorted(self.starts_s, t, side="right") - 1, 0, len(self.legs) - 1)
        out = [np.zeros_like(t) for _ in range(4)]
        for i, leg in enumerate(self.legs):
            m = k == i
            if np.any(m):
                vals = leg(t[m] - self.starts_s[i])
                for o, v in zip(out, vals):
                    o[m] = v
                out[0][m] += self.offsets_m[i]
        return tuple(out)
