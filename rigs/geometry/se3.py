"""SE(3): homogeneous rigid transforms.

``T_a_b`` (4x4) maps points of frame ``b`` into frame ``a``: ``p_a = T_a_b @ p_b``.
"""
from __future__ import annotations

import numpy as np


def make_T(R_a_b: np.ndarray, t_a_b: np.ndarray) -> np.ndarray:
    """(3,3), (3,) -> (4,4) homogeneous transform."""
    T = np.eye(4)
    T[:3, :3] = R_a_b
    T[:3, 3] = np.asarray(t_a_b, dtype=float).reshape(3)
    return T


def inv_T(T_a_b: np.ndarray) -> np.ndarray:
    """(...,4,4) -> (...,4,4) inverse ``T_b_a`` of a rigid transform."""
    T_a_b = np.asarray(T_a_b, dtype=float)
    R_t = np.swapaxes(T_a_b[..., :3, :3], -1, -2)
    out = np.zeros_like(T_a_b)
    out[..., :3, :3] = R_t
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", R_t, T_a_b[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def transform_points(T_a_b: np.ndarray, p_b: np.ndarray) -> np.ndarray:
    """(4,4), (N,3) -> (N,3) points in frame ``a``."""
    p_b = np.asarray(p_b, dtype=float)
    return p_b @ T_a_b[:3, :3].T + T_a_b[:3, 3]
