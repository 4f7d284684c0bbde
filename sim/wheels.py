"""Wheel-encoder ticks of a differential-drive vehicle on a ``VehicleTrajectory``.

Wheel contact points at ``(0, +-track/2, 0)`` in b; wheel ground speed is the forward
component of the contact velocity: ``v_left = v_b.x - omega_b.z track/2``, ``v_right =
v_b.x + omega_b.z track/2``. Distance per sample interval is integrated exactly enough with
5-point Gauss-Legendre; each interval's distance is scaled by ``1 + slip_std * n`` (n ~ N(0,1),
one per wheel and interval, from ``rng``). Ticks are ``floor(cumulative angle / (2 pi) *
ticks_per_rev)`` from 0 at the first sample.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.errors import SimError

_GL_X, _GL_W = np.polynomial.legendre.leggauss(5)


@dataclass(frozen=True)
class WheelSamples:
    """``t_ns`` (N,) int64; cumulative ``left_ticks``, ``right_ticks`` (N,) int64."""

    t_ns: np.ndarray
    left_ticks: np.ndarray
    right_ticks: np.ndarray


def wheel_speeds(states, track_width: float) -> np.ndarray:
    """(N,2) left, right wheel ground speeds (m/s) from ``BodyStates``."""
    v_b = np.einsum("nji,nj->ni", states.T_w_b[:, :3, :3], states.v_w)
    half = 0.5 * track_width * states.omega_b[:, 2]
    return np.stack([v_b[:, 0] - half, v_b[:, 0] + half], axis=1)


def measure_wheels(trajectory, wheels, t_ns, rng: np.random.Generator) -> WheelSamples:
    """Encoder ticks at ``t_ns`` (N,) int64 for ``wheels`` (rigs.Wheels)."""
    t_ns = np.asarray(t_ns, dtype=np.int64).reshape(-1)
    if t_ns.size and np.any(np.diff(t_ns) <= 0):
        raise SimError("measure_wheels: t_ns must be strictly increasing")
    a, b = t_ns[:-1], t_ns[1:]
    half = (b - a).astype(float)[:, None] / 2
    tq = (a[:, None] + np.round(half * (_GL_X + 1)).astype(np.int64)).ravel()
    sp = wheel_speeds(trajectory.states(tq), wheels.track_width).reshape(a.size, _GL_X.size, 2)
    dist = (sp * _GL_W[None, :, None]).sum(1) * half * 1e-9            # (N-1,2) metres
    dist *= 1.0 + wheels.slip_std * rng.standard_normal(dist.shape)
    angle = np.vstack([np.zeros((1, 2)), np.cumsum(dist, axis=0)]) / wheels.wheel_radius
    ticks = np.floor(angle / (2 * np.pi) * int(wheels.ticks_per_rev) + 1e-9).astype(np.int64)
    return WheelSamples(t_ns.copy(), ticks[:, 0].copy(), ticks[:, 1].copy())
