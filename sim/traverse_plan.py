"""Stop-and-go traverse of a rover (seed 001): drive between sites, stop, capture a partial panorama.

The scene's route waypoints are the sites; the rover drives the smooth curve through them
(:mod:`sim.motion`) and stops at each (``Route.stops_m`` at the sites' arc lengths,
:mod:`sim.speed_stops`). While it rests (``dwell_s``) it captures ``n_pairs`` stereo pairs by panning
the mast, one every ``capture_interval_s`` from ``1 s`` after the stop; a site's time is its first
capture. Pan angles are ``pan_step_deg`` apart and centred on the forward direction. Seed 001 says
"7 images with 46 deg FOV and 20 deg overlapping angle" for a 120 deg partial panorama: 7 pointings
20 deg apart span 120 deg of pan (-60..+60 deg) and overlap by 26 deg, while a 20 deg overlap would
span 156 deg; we take 20 deg as the pan step, the only reading consistent with 120 deg. The optional
backward pair (forward-backward mode) is pan 180 deg. Tilt is the rig's nominal tilt (20 deg down).

Mast angles are recorded as commanded and as true: true = commanded + a calibration offset
(pan, tilt) drawn once per dataset (std ``mast_bias_deg``) + a per-pointing repeatability error
(std ``mast_jitter_deg``), both from the ``mast`` stream. The images are rendered at the true angles.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from rigs.model import Wheels
from rigs.typed_config import check_fields, knob
from scenes.registry import make_scene
from sim.errors import SimError
from sim.motion import VehicleTrajectory
from sim.planar_path import arc_length_table, chord_spline
from sim.rng import scene_streams, stream
from sim.sensors.wheels import add_slope_slip, encoder_ticks, measure, with_vehicle_geometry
from sim.vehicles.rover import ROVER, MastHead


@dataclass(frozen=True)
class TraverseConfig:
    """Knobs of a stop-and-go traverse (``--set traverse.<field>``); angles in degrees, times in s."""

    n_pairs: int = knob(7, ge=1, le=15)
    pan_step_deg: float = knob(20.0, gt=0.0, le=60.0)
    backward: bool = knob(False, doc="also a backward pair (pan 180 deg): the forward-backward mode")
    dwell_s: float = knob(20.0, gt=0.0)
    capture_interval_s: float = knob(2.0, gt=0.0)
    mast_bias_deg: float = knob(0.05, ge=0.0, doc="std of the seeded mast calibration offset")
    mast_jitter_deg: float = knob(0.01, ge=0.0, doc="std of the per-pointing repeatability error")
    slip: float = knob(0.10, ge=0.0, le=0.5, doc="mean wheel slip ratio on level ground")
    slip_slope_gain_per_deg: float = knob(0.05, ge=0.0, doc="relative slip increase per degree of slope")
    slip_random_std: float = knob(0.05, ge=0.0, doc="std of the random (Gauss-Markov) slip part")
    slip_corr_s: float = knob(15.0, gt=0.0)
    wheel_rate_hz: float = knob(20.0, gt=0.0)
    max_sites: int = knob(0, ge=0, doc="0: every site; else only the first max_sites (short runs, tests)")

    def __post_init__(self):
        check_fields(self, SimError, "traverse.")
        n = self.n_pairs + int(self.backward)
        if 1.0 + (n - 1) * self.capture_interval_s >= self.dwell_s:
            raise SimError(f"traverse.dwell_s: {self.dwell_s!r} s is too short for {n} captures "
                           f"{self.capture_interval_s} s apart (need > {1.0 + (n - 1) * self.capture_interval_s} s)")

    def pans_deg(self) -> np.ndarray:
        """Commanded pan angles of one site, forward pairs left to right... then the backward one."""
        p = (np.arange(self.n_pairs) - (self.n_pairs - 1) / 2) * self.pan_step_deg
        return np.r_[p, 180.0] if self.backward else p


@dataclass(frozen=True)
class Capture:
    """One mast pointing at one site: ``t_ns``; commanded and true (pan, tilt) in rad."""

    site: int
    pair: int
    t_ns: int
    pan_cmd: float
    tilt_cmd: float
    pan_true: float
    tilt_true: float


@dataclass
class TraversePlan:
    """Scene, the stop-and-go trajectory, the site times/poses and the captures."""

    scene: object
    trajectory: object
    site_s_m: np.ndarray        # arc length of every site
    site_t_ns: np.ndarray       # capture time of every site (its first capture)
    T_w_b_sites: np.ndarray     # (S,4,4) true pose at rest
    captures: list


def site_arc_lengths(route) -> np.ndarray:
    """Arc length (m) of every waypoint along the smooth curve through them (sim.planar_path)."""
    c, u_knots = chord_spline(route, 0.0)
    if len(u_knots) != len(route.waypoints_xy):
        raise SimError(f"traverse route: need >= 6 distinct sites, got {len(route.waypoints_xy)}")
    u_f, S_f = arc_length_table(c, u_knots)
    return np.asarray(S_f)[np.searchsorted(u_f, u_knots)]


def plan(config, tcfg: TraverseConfig) -> TraversePlan:
    """The traverse of ``config`` (a ``GenerateConfig``: scene, rig, motion, seed) under ``tcfg``."""
    scene = make_scene(config.scene_config, scene_streams(config.scene_config.seed))
    route = scene.route
    if tcfg.max_sites:
        route = dataclasses.replace(route, waypoints_xy=route.waypoints_xy[:max(6, tcfg.max_sites)])
    s_sites = site_arc_lengths(route)
    route = dataclasses.replace(route, stops_m=tuple(float(s) for s in s_sites[1:-1]), stop_dwell_s=tcfg.dwell_s)
    motion = dataclasses.replace(config.motion, rest_before_s=tcfg.dwell_s, rest_after_s=tcfg.dwell_s,
                                 start_speed_mps=0.0)
    traj = VehicleTrajectory.from_route(route, scene.ground_height, motion, stream(config.seed, "motion"))
    prof = traj.profile
    rest_start = np.r_[0.0, prof.starts_s[1:], prof.duration - prof.t_rest1]
    return _captures(scene, traj, s_sites, rest_start, tcfg, config)


def _captures(scene, traj, s_sites, rest_start_s, tcfg: TraverseConfig, config) -> TraversePlan:
    rng = stream(config.seed, "mast")
    bias = np.radians(tcfg.mast_bias_deg) * rng.standard_normal(2)
    tilt0 = MastHead.from_rig(config.rig).tilt0_rad
    pans = np.radians(tcfg.pans_deg())
    caps, site_t = [], []
    for k, t0 in enumerate(rest_start_s):
        t_caps = traj.t0_ns + np.round((t0 + 1.0 + np.arange(pans.size) * tcfg.capture_interval_s) * 1e9).astype(np.int64)
        site_t.append(int(t_caps[0]))
        jit = np.radians(tcfg.mast_jitter_deg) * rng.standard_normal((pans.size, 2))
        for j, (t, p) in enumerate(zip(t_caps, pans)):
            caps.append(Capture(k, j, int(t), float(p), tilt0, float(p + bias[0] + jit[j, 0]),
                                float(tilt0 + bias[1] + jit[j, 1])))
    site_t = np.array(site_t, dtype=np.int64)
    return TraversePlan(scene, traj, np.asarray(s_sites), site_t, traj.states(site_t).T_w_b, caps)


def wheel_travel(tp: TraversePlan, tcfg: TraverseConfig, seed: int):
    """Encoder distances of the rover's left/right wheel sides (slope-dependent slip, stream ``wheels``)
    and the ticks of ``rigs.model.Wheels`` with the rover's geometry."""
    traj = tp.trajectory
    t_ns = np.arange(traj.t0_ns, traj.t1_ns + 1, int(round(1e9 / tcfg.wheel_rate_hz)), dtype=np.int64)
    clean = measure(traj, ROVER, t_ns)
    mid = (t_ns[:-1] + t_ns[1:]) // 2
    R = traj.states(mid).T_w_b[:, :3, :3]
    pitch = np.arcsin(np.clip(-R[:, 2, 0], -1, 1))
    slipped = add_slope_slip(clean, pitch, tcfg.slip, tcfg.slip_slope_gain_per_deg, tcfg.slip_random_std,
                             tcfg.slip_corr_s, stream(seed, "wheels"))
    enc = with_vehicle_geometry(Wheels(rate_hz=tcfg.wheel_rate_hz), ROVER)
    return clean, slipped, encoder_ticks(slipped, ROVER.wheel_radius_m, enc.ticks_per_rev), enc
