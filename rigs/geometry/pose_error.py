"""Pose errors: the left-perturbation error between poses and the sample covariance of pose samples.

``T_a`` (...,4,4) rigid transforms; errors are ``[rotation vector (3), translation (3)]``.
"""
from __future__ import annotations

import numpy as np

from rigs.geometry.rotation import so3_log


def pose_error_left(T_a: np.ndarray, T_b: np.ndarray) -> np.ndarray:
    """(...,4,4) x2 -> (...,6) ``[log(R_a R_b^T), t_a - t_b]``: the left-perturbation error of ``T_b``
    against ``T_a`` (the convention of ``FrameResult.cov``)."""
    T_a, T_b = np.asarray(T_a, float), np.asarray(T_b, float)
    dR = np.einsum("...ij,...kj->...ik", T_a[..., :3, :3], T_b[..., :3, :3])
    rot = np.array([so3_log(R) for R in dR.reshape(-1, 3, 3)]).reshape(dR.shape[:-2] + (3,))
    return np.concatenate([rot, T_a[..., :3, 3] - T_b[..., :3, 3]], axis=-1)


def pose_error_cov(T_samples: np.ndarray, T_ref: np.ndarray) -> np.ndarray:
    """(R,...,4,4) samples, (...,4,4) reference -> (...,6,6) sample covariance (about the samples'
    mean, ddof 1) of their left-perturbation errors ``pose_error_left(T_samples, T_ref)``."""
    T_samples = np.asarray(T_samples, float)
    e = pose_error_left(T_samples, np.broadcast_to(T_ref, T_samples.shape))      # (R, ..., 6)
    d = e - e.mean(axis=0)
    return np.einsum("r...i,r...j->...ij", d, d) / (len(e) - 1)
