"""Wheel odometry of a differential-drive vehicle on a ``VehicleTrajectory``: clean measurement,
slip noise, encoder quantisation as three separate steps.

:func:`measure` (the truth): wheel contact points at ``(0, +-track/2, 0)`` in b, the vehicle's own
track (:class:`sim.vehicles.VehicleDims`); wheel ground speed is the forward component of the contact
velocity, ``v_left = v_b.x - omega_b.z track/2``, ``v_right = v_b.x + omega_b.z track/2``; the
distance per sample interval is integrated with 5-point Gauss-Legendre.
:func:`add_slip_noise`: each interval's distance is scaled by ``1 + slip_std * n`` (n ~ N(0,1), one
per wheel and interval, from the ``rng`` it is given). :func:`encoder_ticks`: ``floor(cumulative
angle / (2 pi) * ticks_per_rev)`` from 0 at the first sample, angle = distance / wheel radius.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from rigs.model import Wheels
from rigs.records import WheelSamples
from sim.errors import SimError

_GL_X, _GL_W = np.polynomial.legendre.leggauss(5)


@dataclass(frozen=True)
class WheelTravel:
    """Ground distance rolled by each wheel: ``t_ns`` (N,) int64 sample times, ``dist_m`` (N-1, 2)
    left, right metres over each interval ``[t_k, t_k+1]``."""

    t_ns: np.ndarray
    dist_m: np.ndarray


def wheel_speeds(states, track_m: float) -> np.ndarray:
    """(N,2) left, right wheel ground speeds (m/s) from ``BodyStates``."""
    v_b = np.einsum("nji,nj->ni", states.T_w_b[:, :3, :3], states.v_w)
    half = 0.5 * track_m * states.omega_b[:, 2]
    return np.stack([v_b[:, 0] - half, v_b[:, 0] + half], axis=1)


def measure(trajectory, dims, t_ns) -> WheelTravel:
    """Exact distances rolled by the wheels of a vehicle with ``dims`` between the times ``t_ns``."""
    t_ns = np.asarray(t_ns, dtype=np.int64).reshape(-1)
    if t_ns.size and np.any(np.diff(t_ns) <= 0):
        raise SimError("wheel odometry: t_ns must be strictly increasing")
    a, b = t_ns[:-1], t_ns[1:]
    half = (b - a).astype(float)[:, None] / 2
    tq = (a[:, None] + np.round(half * (_GL_X + 1)).astype(np.int64)).ravel()
    sp = wheel_speeds(trajectory.states(tq), dims.track_m).reshape(a.size, _GL_X.size, 2)
    return WheelTravel(t_ns.copy(), (sp * _GL_W[None, :, None]).sum(1) * half * 1e-9)


def add_slip_noise(travel: WheelTravel, slip_std: float, rng: np.random.Generator) -> WheelTravel:
    """Each interval's distance times ``1 + slip_std * n``; always draws one normal per wheel and interval."""
    scale = 1.0 + float(slip_std) * rng.standard_normal(travel.dist_m.shape)
    return WheelTravel(travel.t_ns.copy(), travel.dist_m * scale)


def encoder_ticks(travel: WheelTravel, wheel_radius_m: float, ticks_per_rev: int) -> WheelSamples:
    """Cumulative encoder ticks of each wheel, 0 at the first sample."""
    angle = np.vstack([np.zeros((1, 2)), np.cumsum(travel.dist_m, axis=0)]) / wheel_radius_m
    ticks = np.floor(angle / (2 * np.pi) * int(ticks_per_rev) + 1e-9).astype(np.int64)
    return WheelSamples(travel.t_ns.copy(), ticks[:, 0].copy(), ticks[:, 1].copy())


def measure_wheels(trajectory, dims, encoder, t_ns, rng: np.random.Generator) -> WheelSamples:
    """The three steps: encoder ticks at ``t_ns`` (N,) int64 of a vehicle with ``dims`` for the
    encoder ``encoder`` (``rigs.Wheels``: ``ticks_per_rev``, ``slip_std``)."""
    travel = add_slip_noise(measure(trajectory, dims, t_ns), encoder.slip_std, rng)
    return encoder_ticks(travel, dims.wheel_radius_m, encoder.ticks_per_rev)


def with_vehicle_geometry(encoder, dims):
    """``encoder`` (``rigs.Wheels``) with ``track_width`` and ``wheel_radius`` those of the vehicle
    (``dims``), the geometry :func:`measure_wheels` uses. A value that is neither the ``rigs.Wheels``
    default nor the vehicle's was set on purpose and is refused (the vehicle owns its dimensions)."""
    default = Wheels()
    for f, v in (("track_width", dims.track_m), ("wheel_radius", dims.wheel_radius_m)):
        got = getattr(encoder, f)
        if got not in (getattr(default, f), v):
            raise SimError(f"wheels.{f}: {got!r}; the vehicle sets it ({v!r} m), remove the override")
    return dataclasses.replace(encoder, track_width=dims.track_m, wheel_radius=dims.wheel_radius_m)


def add_slope_slip(travel: WheelTravel, pitch_rad: np.ndarray, slip: float, slope_gain_per_deg: float,
                   random_std: float, corr_s: float, rng: np.random.Generator) -> WheelTravel:
    """Slip of wheels on loose soil: each interval's encoder distance is the ground distance divided
    by ``1 - s``, ``s = clip(slip (1 + slope_gain_per_deg |pitch_deg|) + r, 0, 0.6)``, the slip
    ratio growing with the slope ``pitch_rad`` (N-1,) of the interval; ``r`` is a seeded random part
    per wheel side, a first-order Gauss-Markov process of std ``random_std`` and correlation time
    ``corr_s`` (two normals per interval drawn from ``rng``)."""
    t = travel.t_ns.astype(float) * 1e-9
    dt = np.diff(t)
    n = rng.standard_normal(travel.dist_m.shape)
    r = np.zeros_like(n)
    phi = np.exp(-dt / max(float(corr_s), 1e-9))
    prev = np.zeros(2)
    for k in range(n.shape[0]):                 # AR(1): r_k = phi r_k-1 + sqrt(1 - phi^2) std n_k
        prev = phi[k] * prev + np.sqrt(1 - phi[k] ** 2) * random_std * n[k]
        r[k] = prev
    base = float(slip) * (1.0 + float(slope_gain_per_deg) * np.abs(np.degrees(np.asarray(pitch_rad, float))))
    s = np.clip(base[:, None] + r, 0.0, 0.6)
    return WheelTravel(travel.t_ns.copy(), travel.dist_m / (1.0 - s))
