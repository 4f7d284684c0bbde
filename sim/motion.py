"""Smooth vehicle motion along a route, with exact analytic derivatives at any time.

Construction (all in world ``w``, z up):

* planar path: a quintic interpolating B-spline through the waypoints, or, with
  ``corner_smoothing_m = sigma > 0``, through the waypoint polyline smoothed by a Gaussian of
  std sigma along its length (straights stay straight, corners are rounded; no overshoot)
  (periodic for closed
  routes, "natural" quintic ends, i.e. 3rd and 4th derivatives zero, for open ones), in
  chord-length parameter, then re-sampled by arc length ``s`` every ``path_sample_m`` and
  re-fitted, so ``|d(x, y)/ds| = 1`` to interpolation accuracy (~1e-9);
* ground: height at the centre and the slope seen by the wheels (central differences over
  ``wheelbase_m`` forward and ``track_m`` sideways), sampled on the same ``s`` grid and
  fitted with the same quintic spline; ``pitch = -atan(g_fwd)``, ``roll = atan(g_left /
  sqrt(1 + g_fwd^2))`` puts body x and y exactly in the plane ``dz = g_fwd df + g_left dl``;
* speed: rest, septic-smoothstep ramp (peak acceleration ``route.accel_mps2``), cruise (the route's
  speed, or ``motion.cruise_speed_mps`` when set), symmetric ramp to rest, rest; ``s(t)`` is C4;
* vibration: heave, pitch, roll, yaw offsets, each a sum of sinusoids with seeded
  amplitudes, phases and frequencies, scaled by ``speed / peak speed`` so it vanishes at rest;
* yaw is the path tangent ``atan2(y', x')`` plus yaw vibration; ``R_w_b = Rz(yaw) Ry(pitch)
  Rx(roll)``; body rates come from the exact ZYX Euler kinematic matrix and its derivative.

The trajectory *is* these splines: the pose follows the terrain to within spline
interpolation error (sub-mm for terrain smoother than ``path_sample_m``), while every
derivative is exact for the defined motion (quintic splines are C4, so ``a_w`` and
``alpha_b`` are continuous).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np
from scipy.interpolate import make_interp_spline

from rigs.trajectory import Trajectory
from rigs.typed_config import check_fields, knob
from sim.errors import SimError
from sim.planar_path import arc_length_table, chord_spline, u_at_arclength
from sim.speed_stops import StopGoProfile
from sim.vehicles.cart import CART

_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)
_RAMP_PEAK = 35.0 / 16.0        # max of h'(tau) for the septic smoothstep h


@dataclass(frozen=True)
class MotionConfig:
    """Knobs of the vehicle motion. Angles in degrees, lengths in metres, times in seconds. YAML and
    ``--set motion.<field>`` keys are the field names, type- and range-checked on construction."""

    start_time_ns: int = knob(1_000_000_000, ge=0)
    start_speed_mps: float = knob(0.0, ge=0.0)
    cruise_speed_mps: float = knob(0.0, ge=0.0, le=60.0, doc="cruise speed (m/s); 0: the scene route's")
    rest_before_s: float = knob(0.0, ge=0.0)
    rest_after_s: float = knob(0.0, ge=0.0)
    vibration_pitch_deg: float = knob(0.3, ge=0.0)
    vibration_roll_deg: float = knob(0.3, ge=0.0)
    vibration_yaw_deg: float = knob(0.1, ge=0.0)
    vibration_heave_m: float = knob(0.003, ge=0.0)
    vibration_freqs_hz: tuple[float, ...] = (0.7, 1.3, 2.1)
    wheelbase_m: float = knob(CART.wheelbase_m, gt=0.0, doc="the cart's (sim.vehicles.cart); set for other vehicles")
    track_m: float = knob(CART.track_m, gt=0.0)
    path_sample_m: float = knob(0.1, gt=0.0)
    corner_smoothing_m: float = knob(0.0, ge=0.0)

    def __post_init__(self):
        check_fields(self, SimError, "motion.")
        if self.start_speed_mps > 0 and self.rest_before_s > 0:
            raise SimError(f"motion.start_speed_mps: {self.start_speed_mps!r} with motion.rest_before_s "
                           f"{self.rest_before_s!r}; a vehicle moving at the start cannot rest first (set one to 0)")
        fr = self.vibration_freqs_hz
        if not fr or not all(0 < f < 50 for f in fr):
            raise SimError(f"motion.vibration_freqs_hz: expected 1+ frequencies in (0, 50) Hz, got {fr!r}")


@dataclass(frozen=True)
class BodyStates:
    """Kinematic state of body ``b`` at times ``t_ns`` (N,).

    ``T_w_b`` (N,4,4); ``v_w``, ``a_w`` (N,3) velocity / acceleration of the body origin in w;
    ``omega_b``, ``alpha_b`` (N,3) angular rate / acceleration of b w.r.t. w, expressed in b.
    """

    t_ns: np.ndarray
    T_w_b: np.ndarray
    v_w: np.ndarray
    a_w: np.ndarray
    omega_b: np.ndarray
    alpha_b: np.ndarray


# ----------------------------------------------------------------------------- speed profile
def _smoothstep7(tau: np.ndarray):
    """Septic smoothstep h, its integral H, and h', h'' on tau in [0, 1]."""
    t = tau
    h = t**4 * (35 - 84 * t + 70 * t**2 - 20 * t**3)
    H = t**5 * (7 - 14 * t + 10 * t**2 - 2.5 * t**3)
    h1 = 140 * t**3 * (1 - t) ** 3
    h2 = 420 * t**2 * (1 - t) ** 2 * (1 - 2 * t)
    return h, H, h1, h2


@dataclass(frozen=True)
class SpeedProfile:
    """Arc length ``s(t)`` (t in s from the start): rest, ramp up (from ``v_start``), cruise, ramp down, rest.

    ``t_ramp`` is the ramp down from ``v_peak`` to rest; the ramp up from ``v_start`` takes
    ``t_ramp_up = t_ramp * (1 - v_start / v_peak)`` with the same peak acceleration.
    """

    length_m: float
    v_peak: float
    t_ramp: float
    t_cruise: float
    t_rest0: float
    t_rest1: float
    v_start: float = 0.0

    @classmethod
    def build(cls, length_m: float, cruise_mps: float, accel_mps2: float, rest0: float, rest1: float,
              v_start: float = 0.0):
        """Peak acceleration of the ramps is ``accel_mps2``; short routes lower the peak speed."""
        v = cruise_mps
        if v_start > v:
            raise SimError(f"motion.start_speed_mps: {v_start!r} exceeds the route's cruise speed {v!r} m/s")
        if length_m < _RAMP_PEAK * (2 * v * v - v_start**2) / (2 * accel_mps2):   # ramps alone cover it
            v = math.sqrt(accel_mps2 * length_m / _RAMP_PEAK + v_start**2 / 2)
            if v < v_start:
                v_max = math.sqrt(2 * accel_mps2 * length_m / _RAMP_PEAK)
                raise SimError(f"motion.start_speed_mps: {v_start!r} m/s is too fast to stop within the "
                               f"{length_m:.1f} m route; at most {v_max:.2f}")
        t_ramp = _RAMP_PEAK * v / accel_mps2
        s_ramps = (v + v_start) / 2 * t_ramp * (1 - v_start / v) + v * t_ramp / 2
        t_cruise = max(0.0, (length_m - s_ramps) / v)
        return cls(length_m, v, t_ramp, t_cruise, rest0, rest1, float(v_start))

    @property
    def t_ramp_up(self) -> float:
        return self.t_ramp * (1.0 - self.v_start / self.v_peak)

    @property
    def duration(self) -> float:
        return self.t_rest0 + self.t_ramp_up + self.t_ramp + self.t_cruise + self.t_rest1

    def __call__(self, t: np.ndarray):
        """(N,) seconds -> s, s', s'', s''' (N,) each."""
        v, v0, T, Tu = self.v_peak, self.v_start, self.t_ramp, self.t_ramp_up
        tt = np.asarray(t, dtype=float) - self.t_rest0
        s, sd, sdd, sddd = (np.zeros_like(tt) for _ in range(4))
        up = (tt >= 0) & (tt < Tu)
        dv = v - v0
        h, H, h1, h2 = _smoothstep7(tt[up] / Tu) if Tu > 0 else (tt[up],) * 4
        s[up], sd[up] = v0 * tt[up] + dv * Tu * H, v0 + dv * h
        if Tu > 0:
            sdd[up], sddd[up] = dv / Tu * h1, dv / Tu**2 * h2
        s_up = (v + v0) / 2 * Tu                     # arc length covered by the ramp up
        cr = (tt >= Tu) & (tt <= Tu + self.t_cruise)
        s[cr], sd[cr] = s_up + v * (tt[cr] - Tu), v
        t_dn = Tu + self.t_cruise
        dn = (tt > t_dn) & (tt < t_dn + T)
        tau = (tt[dn] - t_dn) / T
        h, H, h1, h2 = _smoothstep7(tau)
        s[dn] = s_up + v * self.t_cruise + v * T * (tau - H)
        sd[dn], sdd[dn], sddd[dn] = v * (1 - h), -v / T * h1, -v / T**2 * h2
        s[tt >= t_dn + T] = self.length_m
        return s, sd, sdd, sddd


# ----------------------------------------------------------------------------- rotations
def _euler_zyx(yaw, pitch, roll) -> np.ndarray:
    """R_w_b = Rz(yaw) Ry(pitch) Rx(roll), (N,3,3)."""
    cy, sy, cp, sp, cr, sr = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch), np.cos(roll), np.sin(roll)
    R = np.empty(yaw.shape + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 0, 2] = cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr
    R[..., 1, 0], R[..., 1, 1], R[..., 1, 2] = sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr
    R[..., 2, 0], R[..., 2, 1], R[..., 2, 2] = -sp, cp * sr, cp * cr
    return R


def _body_rates(ang, dang, ddang):
    """ZYX Euler (yaw, pitch, roll) (3,N) and their 1st/2nd time derivatives -> omega_b, alpha_b (N,3).

    omega_b = [r' - y' sp,  p' cr + y' cp sr,  -p' sr + y' cp cr] (exact ZYX kinematics);
    alpha_b is its exact time derivative.
    """
    (_, p, r), (yd, pd, rd), (ydd, pdd, rdd) = ang, dang, ddang
    sp, cp, sr, cr = np.sin(p), np.cos(p), np.sin(r), np.cos(r)
    om = np.stack([rd - yd * sp, pd * cr + yd * cp * sr, -pd * sr + yd * cp * cr], axis=1)
    al = np.stack([
        rdd - ydd * sp - yd * pd * cp,
        pdd * cr - pd * rd * sr + ydd * cp * sr - yd * pd * sp * sr + yd * rd * cp * cr,
        -pdd * sr - pd * rd * cr + ydd * cp * cr - yd * pd * sp * cr - yd * rd * cp * sr,
    ], axis=1)
    return om, al


# ----------------------------------------------------------------------------- vibration
@dataclass(frozen=True)
class _Vibration:
    """Sum of sinusoids per channel (heave m, pitch, roll, yaw rad): amp/freq/phase (4,K)."""

    amp: np.ndarray
    freq: np.ndarray
    phase: np.ndarray

    @classmethod
    def draw(cls, config: MotionConfig, rng: np.random.Generator):
        """Amplitudes have root-sum-square equal to the configured amplitude; freqs jittered +-15 %."""
        k = len(config.vibration_freqs_hz)
        rss = np.array([config.vibration_heave_m, *np.radians([config.vibration_pitch_deg,
                        config.vibration_roll_deg, config.vibration_yaw_deg])])
        w = rng.uniform(0.5, 1.0, size=(4, k))
        amp = rss[:, None] * w / np.linalg.norm(w, axis=1, keepdims=True)
        freq = np.asarray(config.vibration_freqs_hz)[None, :] * rng.uniform(0.85, 1.15, size=(4, k))
        phase = rng.uniform(0.0, 2 * np.pi, size=(4, k))
        return cls(amp, freq, phase)

    def __call__(self, t: np.ndarray):
        """(N,) s -> value, d/dt, d2/dt2, each (4,N)."""
        w = 2 * np.pi * self.freq[:, :, None]
        arg = w * t[None, None, :] + self.phase[:, :, None]
        a = self.amp[:, :, None]
        return ((a * np.sin(arg)).sum(1), (a * w * np.cos(arg)).sum(1), (-a * w * w * np.sin(arg)).sum(1))


# ----------------------------------------------------------------------------- trajectory
def _fit_s_spline(s: np.ndarray, values: np.ndarray, closed: bool):
    """Quintic spline in arc length of values (M+1, C); periodic or natural quintic ends."""
    if closed:
        values = values.copy()
        values[-1] = values[0]
        return make_interp_spline(s, values, k=5, bc_type="periodic")
    nat = [(3, np.zeros(values.shape[1])), (4, np.zeros(values.shape[1]))]
    return make_interp_spline(s, values, k=5, bc_type=(nat, nat))


def _ground_attitude(xy, t_hat, ground_height, wheelbase, track):
    """Centre height, pitch, roll (M,) from the terrain under the wheels (see module doc)."""
    n_hat = np.stack([-t_hat[:, 1], t_hat[:, 0]], axis=1)           # left normal

    def h(p):
        return np.broadcast_to(np.asarray(ground_height(p[:, 0], p[:, 1]), dtype=float), (p.shape[0],))

    z = h(xy)
    g_fwd = (h(xy + wheelbase / 2 * t_hat) - h(xy - wheelbase / 2 * t_hat)) / wheelbase
    g_left = (h(xy + track / 2 * n_hat) - h(xy - track / 2 * n_hat)) / track
    if not (np.all(np.isfinite(z)) and np.all(np.isfinite(g_fwd)) and np.all(np.isfinite(g_left))):
        raise SimError("ground_height: returned NaN or inf along the route")
    return z, -np.arctan(g_fwd), np.arctan(g_left / np.sqrt(1 + g_fwd**2))


def path_length_m(states: Callable, t0_ns: int, t1_ns: int) -> float:
    """3-D length (m) of the body origin's path over [t0_ns, t1_ns]: 16-point Gauss-Legendre on |v_w| over
    0.25 s panels. ``states``: (N,) int64 ns -> :class:`BodyStates`."""
    dur = (t1_ns - t0_ns) * 1e-9
    n = max(1, int(math.ceil(dur / 0.25)))
    edges = np.linspace(0.0, dur, n + 1)
    half = np.diff(edges)[:, None] / 2
    tt = (edges[:-1, None] + half * (_GL_X + 1)).ravel()
    sp = np.linalg.norm(states(t0_ns + np.round(tt * 1e9).astype(np.int64)).v_w, axis=1)
    return float((sp.reshape(n, -1) * _GL_W * half).sum())


class VehicleTrajectory:
    """The vehicle's motion; query any time with :meth:`states` (vectorised over int64 ns)."""

    def __init__(self, spline, closed: bool, profile: SpeedProfile, vibration: _Vibration,
                 t0_ns: int, t1_ns: int):
        self._F = [spline] + [spline.derivative(k) for k in (1, 2, 3)]
        self.closed = closed
        self.profile = profile
        self._vib = vibration
        self.t0_ns = int(t0_ns)
        self.t1_ns = int(t1_ns)

    @classmethod
    def from_route(cls, route, ground_height: Callable, config: MotionConfig, rng: np.random.Generator,
                   duration_s: Optional[float] = None) -> "VehicleTrajectory":
        """Build the motion along ``route`` (scenes.base.Route) at its cruise speed, or at
        ``config.cruise_speed_mps`` when that is set; ``duration_s`` only truncates ``t1_ns``."""
        if config.cruise_speed_mps > 0:
            route = dataclasses.replace(route, cruise_speed_mps=float(config.cruise_speed_mps))
        c, u_knots = chord_spline(route, config.corner_smoothing_m)
        u_f, S_f = arc_length_table(c, u_knots)
        length = float(S_f[-1])
        m = max(12, int(math.ceil(length / config.path_sample_m)))
        s = np.linspace(0.0, length, m + 1)
        u = u_at_arclength(c, u_f, S_f, s)
        xy, dxy = c(u), c.derivative()(u)
        t_hat = dxy / np.linalg.norm(dxy, axis=1, keepdims=True)
        z, pitch, roll = _ground_attitude(xy, t_hat, ground_height, config.wheelbase_m, config.track_m)
        spline = _fit_s_spline(s, np.column_stack([xy, z, pitch, roll]), route.closed)
        if getattr(route, "stops_m", ()):                             # stop-and-go legs (sim.speed_stops)
            profile = StopGoProfile.build(length, route, config, SpeedProfile.build)
        else:
            profile = SpeedProfile.build(length, route.cruise_speed_mps, route.accel_mps2,
                                         config.rest_before_s, config.rest_after_s, config.start_speed_mps)
        dur = profile.duration
        if duration_s is not None:
            if not (isinstance(duration_s, (int, float)) and duration_s > 0):
                raise SimError(f"duration_s: must be a positive number of seconds, got {duration_s!r}")
            dur = min(dur, float(duration_s))
        t0 = int(config.start_time_ns)
        return cls(spline, route.closed, profile, _Vibration.draw(config, rng), t0, t0 + int(round(dur * 1e9)))

    @property
    def route_length_m(self) -> float:
        """Planar arc length of the smooth route curve (m)."""
        return float(self.profile.length_m)

    def _rel_s(self, t_ns) -> np.ndarray:
        t_ns = np.asarray(t_ns, dtype=np.int64).reshape(-1)
        return (t_ns - np.int64(self.t0_ns)).astype(float) * 1e-9

    def states(self, t_ns) -> BodyStates:
        """Exact pose, velocities and accelerations at ``t_ns`` (N,) int64."""
        t_ns = np.asarray(t_ns, dtype=np.int64).reshape(-1)
        t = self._rel_s(t_ns)
        s, sd, sdd, sddd = self.profile(t)
        F0, F1, F2, F3 = (f(s).T for f in self._F)                    # each (5,N)
        vib, vib_d, vib_dd = self._enveloped_vibration(t, sd, sdd, sddd)
        p = np.stack([F0[0], F0[1], F0[2] + vib[0]], axis=1)
        v = (F1[:3] * sd).T
        v[:, 2] += vib_d[0]
        a = (F2[:3] * sd**2 + F1[:3] * sdd).T
        a[:, 2] += vib_dd[0]
        ang, dang, ddang = self._angles(F0, F1, F2, F3, sd, sdd, vib, vib_d, vib_dd)
        T = np.zeros((t.size, 4, 4))
        T[:, :3, :3] = _euler_zyx(*ang)
        T[:, :3, 3] = p
        T[:, 3, 3] = 1.0
        om, al = _body_rates(ang, dang, ddang)
        return BodyStates(t_ns, T, v, a, om, al)

    def _enveloped_vibration(self, t, sd, sdd, sddd):
        """Vibration (4,N) x3 scaled by e = speed / peak speed (so it is zero, with its derivatives, at rest)."""
        V, Vd, Vdd = self._vib(t)
        vp = self.profile.v_peak
        e, ed, edd = sd / vp, sdd / vp, sddd / vp
        return e * V, ed * V + e * Vd, edd * V + 2 * ed * Vd + e * Vdd

    @staticmethod
    def _angles(F0, F1, F2, F3, sd, sdd, vib, vib_d, vib_dd):
        """(yaw, pitch, roll) and their 1st, 2nd time derivatives, each (3,N)."""
        x1, y1, x2, y2, x3, y3 = F1[0], F1[1], F2[0], F2[1], F3[0], F3[1]
        num, den = x1 * y2 - y1 * x2, x1**2 + y1**2
        yaw_s = num / den                                              # d yaw / ds
        yaw_ss = ((x1 * y3 - y1 * x3) * den - num * 2 * (x1 * x2 + y1 * y2)) / den**2
        ang = np.stack([np.arctan2(y1, x1), F0[3], F0[4]]) + vib[1:][[2, 0, 1]]
        d_s = np.stack([yaw_s, F1[3], F1[4]])
        dd_s = np.stack([yaw_ss, F2[3], F2[4]])
        dang = d_s * sd + vib_d[1:][[2, 0, 1]]
        ddang = dd_s * sd**2 + d_s * sdd + vib_dd[1:][[2, 0, 1]]
        return ang, dang, ddang

    def path_length(self) -> float:
        """3-D length (m) of the body origin's path over [t0_ns, t1_ns] (Gauss-Legendre on |v_w|)."""
        return path_length_m(self.states, self.t0_ns, self.t1_ns)

    def pass_times_ns(self, points_xy) -> np.ndarray:
        """(K,2) world points -> (K,) int64 times the origin passes closest (first pass if tied)."""
        P = np.asarray(points_xy, dtype=float).reshape(-1, 2)
        L = self.profile.length_m
        grid = np.linspace(0.0, L, max(100, int(L / 0.02)) + 1)
        xy = self._F[0](grid)[:, :2]
        d2 = ((xy[None, :, :] - P[:, None, :]) ** 2).sum(-1)
        s = grid[np.argmin(d2, axis=1)]
        for _ in range(8):                                             # Newton on d/ds |c(s)-p|^2 = 0
            r = self._F[0](s)[:, :2] - P
            c1, c2 = self._F[1](s)[:, :2], self._F[2](s)[:, :2]
            g, H = (r * c1).sum(1), (c1 * c1).sum(1) + (r * c2).sum(1)
            s = np.clip(s - g / np.where(H > 1e-9, H, 1.0), 0.0, L)
        return self.t0_ns + np.round(self._time_at_s(s) * 1e9).astype(np.int64)

    def _time_at_s(self, s: np.ndarray) -> np.ndarray:
        """Seconds from t0 at which arc length ``s`` is first reached (bisection to < 1 ns)."""
        pr = self.profile
        lo = np.full(s.shape, pr.t_rest0)
        hi = np.full(s.shape, pr.duration - pr.t_rest1)
        for _ in range(60):
            mid = (lo + hi) / 2
            ahead = pr(mid)[0] >= s
            hi, lo = np.where(ahead, mid, hi), np.where(ahead, lo, mid)
        return hi

    def to_trajectory(self, t_ns):
        """Poses ``T_w_b`` at ``t_ns`` as a ``rigs.trajectory.Trajectory``."""
        st = self.states(t_ns)
        return Trajectory(st.t_ns, st.T_w_b, ref="w", frame="b")
