"""Example trajectories to replay (``generate --motion FILE``): a helix and a seeded hand-held walk.

``vo-testbed motion-example helix|walk OUT.txt [--seed N] [--rate HZ] [--duration S]`` writes a TUM file
of body poses (x forward along the motion, z up) inside the ``indoor`` scene's south-west room
(x in [1, 7], y in [0.8, 4.2], z in [0, 0.6]: body origins of a rig whose cameras sit 1.2 m above ``b``, as
cart27's, so the cameras move between 1.2 and 1.8 m).
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import R_from_opk_deg
from rigs.trajectory import Trajectory
from rigs.trajfile import write_tum
from sim.rng import stream


def _Rz(yaw):
    c, s = np.cos(yaw), np.sin(yaw)
    R = np.zeros(yaw.shape + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1], R[..., 2, 2] = c, -s, s, c, 1.0
    return R


def helix(duration_s: float = 10.0, rate_hz: float = 100.0, centre=(4.0, 2.5, 0.0), radius_m: float = 1.2,
          climb_m: float = 0.6, turns: float = 1.0) -> Trajectory:
    """Body on a helix, looking along its horizontal tangent, rolled 10 deg inwards; t from 1 s."""
    t = np.arange(0.0, duration_s + 1e-9, 1.0 / rate_hz)
    ph = 2 * np.pi * turns * t / duration_s
    T = np.tile(np.eye(4), (t.size, 1, 1))
    T[:, 0, 3] = centre[0] + radius_m * np.cos(ph)
    T[:, 1, 3] = centre[1] + radius_m * np.sin(ph)
    T[:, 2, 3] = centre[2] + climb_m * t / duration_s
    T[:, :3, :3] = _Rz(ph + np.pi / 2) @ R_from_opk_deg(-10.0, 0.0, 0.0)
    return Trajectory(1_000_000_000 + np.round(t * 1e9).astype(np.int64), T, "w", "b")


def hand_walk(seed: int = 0, duration_s: float = 10.0, rate_hz: float = 100.0) -> Trajectory:
    """A hand-held-like walk: slow forward drift along x at ~0.4 m/s plus band-limited random sway
    (position +-5 cm, heading +-20 deg, pitch/roll +-5 deg), from stream ``motion``; t from 1 s."""
    rng = stream(seed, "motion")
    t = np.arange(0.0, duration_s + 1e-9, 1.0 / rate_hz)
    freqs = rng.uniform(0.2, 1.5, size=(6, 4))
    amps = rng.uniform(0.5, 1.0, size=(6, 4))
    amps /= amps.sum(axis=1, keepdims=True)
    ph = rng.uniform(0, 2 * np.pi, size=(6, 4))
    sway = (amps[:, :, None] * np.sin(2 * np.pi * freqs[:, :, None] * t + ph[:, :, None])).sum(1)   # (6, N)
    scale = np.array([0.05, 0.05, 0.05, 20.0, 5.0, 5.0])[:, None]
    sway = sway * scale
    T = np.tile(np.eye(4), (t.size, 1, 1))
    T[:, 0, 3] = 1.5 + 0.4 * t + sway[0]
    T[:, 1, 3] = 2.5 + sway[1]
    T[:, 2, 3] = 0.2 + sway[2]
    T[:, :3, :3] = np.stack([R_from_opk_deg(r, p, 0.0) for p, r in zip(sway[4], sway[5])])
    T[:, :3, :3] = _Rz(np.radians(sway[3])) @ T[:, :3, :3]
    return Trajectory(1_000_000_000 + np.round(t * 1e9).astype(np.int64), T, "w", "b")
