"""Plain measurement records, one type per measurement: what the simulator's sensors produce and its
writers write, and what the dataset readers hand to the estimators."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class StereoFrame:
    """One stereo epoch: ``left``/``right`` (H,W) uint8 grayscale, mid-exposure time ``t_ns``."""

    index: int
    t_ns: int
    left: np.ndarray
    right: np.ndarray


@dataclass(frozen=True)
class ImuSamples:
    """IMU samples in the IMU frame i: ``t_ns`` (N,) int64, ``gyro`` (N,3) rad/s, ``accel`` (N,3) m/s^2."""

    t_ns: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray

    def __len__(self) -> int:
        return int(self.t_ns.shape[0])


@dataclass(frozen=True)
class Gcp:
    """Ground check point: the vehicle passes over ``ground_w`` at ``t_ns``; ``p_w_c0`` is the
    true left-camera position at that time (what a VO estimate is compared with)."""

    name: str
    t_ns: int
    ground_w: np.ndarray = field(repr=False)
    p_w_c0: np.ndarray = field(repr=False)


@dataclass(frozen=True)
class WheelSamples:
    """Wheel-encoder samples: ``t_ns`` (N,) int64 and cumulative ``left_ticks``, ``right_ticks`` (N,)
    int64 (0 at the first sample). Ticks per revolution, wheel radius and track: ``rig.wheels``."""

    t_ns: np.ndarray
    left_ticks: np.ndarray
    right_ticks: np.ndarray
