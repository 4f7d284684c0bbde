"""IMU noise: white noise plus bias random walk, Kalibr densities (``CONVENTIONS.md``).

``accel_meas = accel + b_a + n_a``, ``gyro_meas = gyro + b_g + n_g``;
discrete white std ``density * sqrt(rate_hz)`` (``rate_hz`` from the ``rigs.Imu``);
bias step between samples k-1 and k has std ``random_walk * sqrt(dt_k)`` with ``dt_k`` from
the timestamps, which is ``random_walk / sqrt(rate_hz)`` for uniform sampling.
White noise draws come only from ``rng_white`` (gyro (N,3) then accel (N,3)); biases only
from ``rng_bias`` (initial gyro, initial accel, then gyro steps, accel steps), so changing
one stream never changes the other's contribution.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim.errors import SimError
from rigs.records import ImuSamples


@dataclass(frozen=True)
class ImuBiases:
    """True biases at each sample: ``t_ns`` (N,), ``b_g`` (N,3) rad/s, ``b_a`` (N,3) m/s^2."""

    t_ns: np.ndarray
    b_g: np.ndarray
    b_a: np.ndarray


def _check_std(value, name: str) -> float:
    v = float(value)
    if not math.isfinite(v) or v < 0:
        raise SimError(f"add_imu_noise.{name}: must be a non-negative finite number, got {value!r}")
    return v


def add_imu_noise(clean: ImuSamples, imu, rng_white: np.random.Generator, rng_bias: np.random.Generator,
                  initial_gyro_bias_std: float = 0.0, initial_accel_bias_std: float = 0.0):
    """-> (noisy ``ImuSamples``, true ``ImuBiases``). An ideal IMU (all densities 0, initial stds 0)
    returns the clean values unchanged and zero biases (still drawing the same numbers)."""
    sg0 = _check_std(initial_gyro_bias_std, "initial_gyro_bias_std")
    sa0 = _check_std(initial_accel_bias_std, "initial_accel_bias_std")
    t = np.asarray(clean.t_ns, dtype=np.int64)
    n = t.shape[0]
    if n == 0:
        z = np.zeros((0, 3))
        return ImuSamples(t.copy(), z, z.copy()), ImuBiases(t.copy(), z.copy(), z.copy())
    if n > 1 and np.any(np.diff(t) <= 0):
        raise SimError("add_imu_noise: t_ns must be strictly increasing")
    dt = np.diff(t).astype(float) * 1e-9
    sq = math.sqrt(imu.rate_hz)
    n_g = rng_white.standard_normal((n, 3)) * (imu.gyro_noise_density * sq)
    n_a = rng_white.standard_normal((n, 3)) * (imu.accel_noise_density * sq)
    b_g0 = rng_bias.standard_normal(3) * sg0
    b_a0 = rng_bias.standard_normal(3) * sa0
    b_g = b_g0 + _walk(rng_bias, dt, imu.gyro_random_walk)
    b_a = b_a0 + _walk(rng_bias, dt, imu.accel_random_walk)
    noisy = ImuSamples(t.copy(), clean.gyro + b_g + n_g, clean.accel + b_a + n_a)
    return noisy, ImuBiases(t.copy(), b_g, b_a)


def _walk(rng: np.random.Generator, dt: np.ndarray, rw_density: float) -> np.ndarray:
    """(N,3) random walk starting at 0 with step std ``rw_density * sqrt(dt_k)``."""
    steps = rng.standard_normal((dt.shape[0], 3)) * (rw_density * np.sqrt(dt))[:, None]
    return np.vstack([np.zeros((1, 3)), np.cumsum(steps, axis=0)])
