"""Rotation-only fit between two epochs and the rotation-compensated parallax (our extension).

Seed 000 is silent about standstill: with no translation between epochs the essential matrices
of ROPs 1-3 and 2-4 are undefined (``x3^T [t]x R x1 = 0`` for every ``t`` when ``x3 ~ R x1``)
and the rays 1-3 / 2-4 have no direction. We fit ``R_3_1`` to the bearing vectors
(``b3 ~ R_3_1 b1``, Kabsch / SVD, one refit without the residuals above ``3 x median``) and
measure the parallax as the median residual angle times the focal length: the image motion that
a rotation cannot explain, i.e. the part due to translation. Below a threshold the estimator
treats the epoch as "no translation" instead of solving the essential matrices.
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import make_T

MIN_ROTATION_TRACKS = 8     # tracks for a rotation-only fit of a failed or coasted frame (rop, klt-pnp)


def bearings(x: np.ndarray) -> np.ndarray:
    """(N,2) normalized image coordinates -> (N,3) unit bearing vectors."""
    b = np.c_[x, np.ones(len(x))]
    return b / np.linalg.norm(b, axis=1, keepdims=True)


def kabsch(b_a: np.ndarray, b_b: np.ndarray) -> np.ndarray:
    """Rotation ``R`` minimising ``sum |b_b - R b_a|^2`` (rows are vectors), det = +1."""
    U, _, Vt = np.linalg.svd(b_a.T @ b_b)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
    return Vt.T @ D @ U.T


def rotation_only(x_1: np.ndarray, x_3: np.ndarray, focal: float) -> tuple[np.ndarray, float, np.ndarray]:
    """``(R_1_3 (3,3), parallax_px, residual_px (N,))`` for normalized matches of images 1 and 3.

    Identity and zero parallax for fewer than 3 points (nothing to measure)."""
    if len(x_1) < 3:
        return np.eye(3), 0.0, np.zeros(len(x_1))
    b1, b3 = bearings(x_1), bearings(x_3)
    R_3_1 = kabsch(b1, b3)
    for _ in range(2):
        res = np.linalg.norm(b3 - b1 @ R_3_1.T, axis=1) * focal
        keep = res <= max(3.0 * float(np.median(res)), 0.5)
        if keep.sum() >= 3:
            R_3_1 = kabsch(b1[keep], b3[keep])
    res = np.linalg.norm(b3 - b1 @ R_3_1.T, axis=1) * focal
    return R_3_1.T, float(np.median(res)), res


def rotation_only_step(R_1_3: np.ndarray, parallax: float, n: int, disparity: float, focal: float, baseline: float,
                       min_parallax_px: float) -> tuple:
    """A "no translation" epoch ``T_kf_c = (R_1_3, 0)`` -> ``(T (4,4), cov (6,6), epoch)``: rotation sigma
    ``3 max(parallax, 0.1 px) / (f sqrt(n))``, position sigma ``baseline x max(parallax, min_parallax / 2) /
    median disparity`` per axis (``n`` tracks, ``disparity`` their median keyframe disparity, px)."""
    cov = np.zeros((6, 6))
    s_rot = 3.0 * max(parallax, 0.1) / (focal * np.sqrt(max(n, 1)))
    s_pos = baseline * max(parallax, 0.5 * min_parallax_px) / max(disparity, 1.0)
    cov[:3, :3], cov[3:, 3:] = s_rot ** 2 * np.eye(3), s_pos ** 2 * np.eye(3)
    T = make_T(R_1_3, np.zeros(3))
    return T, cov, ("rotation_only", T, T, None, None)
