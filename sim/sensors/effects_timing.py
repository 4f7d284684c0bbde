"""When each image row is exposed: motion blur (exposure) and rolling shutter, as row weights over renders.

Time convention (CONVENTIONS.md): a frame's time ``t`` is the mid-exposure time of its centre row; row
``r`` of an ``h``-row image is exposed over ``[c_r - E/2, c_r + E/2]`` with ``c_r = t + (r - (h-1)/2) d``
(exposure ``E``, line delay ``d``; readout ``R = (h-1) d``). The frame is rendered at ``N`` poses
("nodes") spread over the whole span ``[t - R/2 - E/2, t + R/2 + E/2]`` and each output row is a
weighted sum of the same row of the ``N`` renders (:func:`assemble`):

- ``E > 0``: node ``n`` stands for the cell of width ``h_n = (R+E)/N`` around it and row ``r``'s weight
  is the part of its exposure window inside that cell, over ``E`` (the midpoint rule of the exposure
  integral; blur only: ``N = blur_subframes`` equal weights).
- ``E = 0`` (rolling shutter alone): rows between two nodes interpolate them linearly in time
  (``N = rs_poses`` nodes over the readout). A feature moving ``m`` px between nodes is cross-faded,
  not shifted: its intensity centroid (the first moment of the row profile) moves exactly linearly,
  its sharpness is that of two ghosts ``m`` px apart. ``m = (image speed) R / (N - 1)``: with
  ``rs_poses = 5`` and a 14 ms readout, 3.5 ms between nodes (``m`` = 1.5 px at 0.3 rad/s yaw and
  f = 460 px).

``N`` is made odd so that the middle node is at ``t`` exactly: depth and segmentation are that render's.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_NODES = 33


@dataclass(frozen=True)
class ExposurePlan:
    """Render times relative to the frame time and the (H, N) row weights (each row sums to 1)."""

    offsets_ns: np.ndarray
    weights: np.ndarray
    centre: int


def exposure_plan(exposure_ms: float, line_delay_us: float, height: int, blur_subframes: int = 5,
                  rs_poses: int = 5) -> ExposurePlan:
    """The nodes and row weights for an ``height``-row image (module docstring)."""
    E = exposure_ms * 1e-3
    d = line_delay_us * 1e-6
    R = (height - 1) * d
    centres = (np.arange(height) - (height - 1) / 2.0) * d
    if E > 0:
        step = E / blur_subframes if R == 0 else min(E / blur_subframes, R / (rs_poses - 1))
        n = min(MAX_NODES, int(np.ceil((R + E) / step - 1e-9)))
        n += 1 - n % 2
        cell = (R + E) / n
        tau = -(R + E) / 2.0 + (np.arange(n) + 0.5) * cell
        lo = np.maximum(centres[:, None] - E / 2.0, tau[None, :] - cell / 2.0)
        hi = np.minimum(centres[:, None] + E / 2.0, tau[None, :] + cell / 2.0)
        w = np.clip(hi - lo, 0.0, None) / E
    elif R > 0:
        n = rs_poses + 1 - rs_poses % 2
        tau = np.linspace(-R / 2.0, R / 2.0, n)
        w = np.clip(1.0 - np.abs(centres[:, None] - tau[None, :]) / (R / (n - 1)), 0.0, None)
    else:
        tau, w = np.zeros(1), np.ones((height, 1))
    w = w / w.sum(axis=1, keepdims=True)
    return ExposurePlan(np.rint(tau * 1e9).astype(np.int64), w, int(len(tau) // 2))


def assemble(renders, weights: np.ndarray) -> np.ndarray:
    """Row-weighted sum of ``N`` renders (each (H,W) or (H,W,C)) -> float32 image of the same shape."""
    stack = np.stack([np.asarray(r, np.float32) for r in renders])
    return np.einsum("hn,nh...->h...", weights.astype(np.float32), stack)


def frame_stamps_ns(frame_t_ns: np.ndarray, jitter_us: float, rng: np.random.Generator) -> np.ndarray:
    """Written stamps: the true frame times plus iid Gaussian jitter (std ``jitter_us``), clipped to a
    quarter of the frame period so stamps stay increasing; ``jitter_us = 0`` draws nothing."""
    t = np.asarray(frame_t_ns, np.int64)
    if jitter_us <= 0:
        return t.copy()
    period = float(np.median(np.diff(t))) if len(t) > 1 else 1e9
    e = np.clip(rng.normal(0.0, jitter_us * 1e3, len(t)), -period / 4, period / 4)
    return t + np.rint(e).astype(np.int64)


def blur_lengths_px(T_w_c_start: np.ndarray, T_w_c_end: np.ndarray, T_w_c_mid: np.ndarray, cam,
                    depth_m: float = 5.0) -> tuple:
    """Per-frame image motion over the exposure (px, pinhole model): the largest over a 3 x 3 grid of pixels
    (10 %, 50 %, 90 % of width and height) of the motion of the point ``depth_m`` in front of the
    mid-exposure camera along that pixel's ray, and the same for points at infinity (rotation alone).
    Poses (N,4,4) of the camera at exposure start, end and middle; ``cam``: rigs.model.Camera."""
    u, v = np.meshgrid(np.array([0.1, 0.5, 0.9]) * cam.width, np.array([0.1, 0.5, 0.9]) * cam.height)
    rays = np.stack([(u.ravel() - cam.cx) / cam.fx, (v.ravel() - cam.cy) / cam.fy, np.ones(9)], axis=1)   # (9,3)
    R_mid = T_w_c_mid[:, :3, :3]
    d_w = np.einsum("nij,kj->nki", R_mid, rays)                                     # (N,9,3)
    p_w = depth_m * d_w + T_w_c_mid[:, None, :3, 3]

    def pix(T, x_w, point: bool):
        x_c = np.einsum("nji,nkj->nki", T[:, :3, :3], x_w - (T[:, None, :3, 3] if point else 0.0))
        return np.stack([cam.fx * x_c[..., 0] / x_c[..., 2], cam.fy * x_c[..., 1] / x_c[..., 2]], axis=-1)

    near = np.linalg.norm(pix(T_w_c_end, p_w, True) - pix(T_w_c_start, p_w, True), axis=-1).max(axis=1)
    far = np.linalg.norm(pix(T_w_c_end, d_w, False) - pix(T_w_c_start, d_w, False), axis=-1).max(axis=1)
    return near, far
