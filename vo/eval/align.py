"""Aligning an estimated trajectory onto ground truth (Umeyama SE(3)/Sim(3), 4-DoF, first pose).

The aligned estimate is ``T'_k = [[s R R_k, s R t_k + t], [0, 1]]`` for ``AlignInfo(R, t, s)``:
positions map as ``p' = s R p + t``, orientations as ``R' = R R_k``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vo.errors import VoError
from rigs.geometry import inv_T
from rigs.trajectory import Trajectory

ALIGN_METHODS = ("se3", "sim3", "none", "first", "posyaw")
DEFAULT_ALIGN = "first"          # the default of ``vo-testbed eval`` and :func:`vo.eval.evaluate`
ALIGN_TEXT = {"first": "first estimated pose put on the first ground-truth pose",
              "se3": "Umeyama SE(3) on the matched positions", "sim3": "Umeyama Sim(3) on the matched positions",
              "posyaw": "translation and yaw (4-DoF) on the matched positions", "none": "none, poses as given"}


def alignment_header(method: str, scale: float | None = None) -> str:
    """``"first (the default): first estimated pose put on ..."`` or ``"se3 (default: first): Umeyama ..."``:
    the alignment used, and eval's default, as every evaluation table states it in its header."""
    which = "the default" if method == DEFAULT_ALIGN else f"default: {DEFAULT_ALIGN}"
    return f"{method} ({which}): {ALIGN_TEXT.get(method, method)}" + (f", scale {scale:.6f}" if method == "sim3" and scale is not None else "")


@dataclass(frozen=True)
class AlignInfo:
    """The applied similarity ``p_gt = s R p_est + t``: ``R`` (3,3), ``t`` (3,), ``s``; ``method`` name."""

    R: np.ndarray
    t: np.ndarray
    s: float
    method: str

    def to_dict(self) -> dict:
        return {"method": self.method, "R": np.asarray(self.R).tolist(),
                "t": np.asarray(self.t).tolist(), "s": float(self.s)}


def umeyama(src: np.ndarray, dst: np.ndarray, with_scale: bool) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares ``dst ~= s R src + t`` (Umeyama 1991, eqs. 34-42) for (N,3) point sets.

    Includes the reflection fix (``S = diag(1, 1, -1)`` when ``det(U) det(V) < 0``), so ``R`` is a
    proper rotation. ``with_scale=False`` gives ``s = 1`` (SE(3)). Returns ``(R (3,3), t (3,), s)``.
    """
    src, dst = np.asarray(src, dtype=float), np.asarray(dst, dtype=float)
    if src.shape != dst.shape or src.ndim != 2 or src.shape[1] != 3 or src.shape[0] < 3:
        raise VoError(f"umeyama: need two (N,3) point sets with N >= 3, got {src.shape} and {dst.shape}")
    mu_s, mu_d = src.mean(0), dst.mean(0)
    xs, xd = src - mu_s, dst - mu_d
    cov = xd.T @ xs / src.shape[0]                    # Sigma_xy of the paper (dst x src)
    U, D, Vt = np.linalg.svd(cov)
    S = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        S[2, 2] = -1.0
    R = U @ S @ Vt
    var_s = np.mean(np.sum(xs ** 2, axis=1))
    if with_scale and var_s <= 0:
        raise VoError("umeyama: source points have zero spread, scale undefined")
    s = float(np.trace(np.diag(D) @ S) / var_s) if with_scale else 1.0
    t = mu_d - s * R @ mu_s
    return R, t, s


def _posyaw(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """4-DoF alignment (translation + yaw about world z), closed form for the yaw angle."""
    xs, xd = src - src.mean(0), dst - dst.mean(0)
    yaw = np.arctan2(np.sum(xs[:, 0] * xd[:, 1] - xs[:, 1] * xd[:, 0]),
                     np.sum(xs[:, 0] * xd[:, 0] + xs[:, 1] * xd[:, 1]))
    c, sn = np.cos(yaw), np.sin(yaw)
    R = np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])
    return R, dst.mean(0) - R @ src.mean(0), 1.0


def apply_alignment(est: Trajectory, R: np.ndarray, t: np.ndarray, s: float) -> Trajectory:
    """``T'_k = [[R R_k, s R t_k + t], [0, 1]]``; the result keeps ``est``'s frame names."""
    T = est.T.copy()
    T[:, :3, :3] = np.einsum("ij,njk->nik", R, est.rotations)
    T[:, :3, 3] = s * est.positions @ np.asarray(R).T + np.asarray(t)
    return Trajectory(est.t_ns, T, est.ref, est.frame)


def align(est: Trajectory, gt: Trajectory, method: str = "se3") -> tuple[Trajectory, AlignInfo]:
    """Align associated ``est`` onto ``gt`` (same length, pose k matched to pose k).

    Methods: ``se3``/``sim3`` Umeyama on positions; ``posyaw`` translation + yaw; ``none``;
    ``first`` anchors the first estimate pose onto the first gt pose,
    ``T' = T_gt0 @ inv(T_est0) @ T_est`` (how drift of VO that starts at identity is judged).
    """
    if method not in ALIGN_METHODS:
        raise VoError(f"unknown alignment method {method!r}; valid: {', '.join(ALIGN_METHODS)}")
    if len(est) != len(gt) or len(est) == 0:
        raise VoError(f"align: est and gt must be associated (same non-zero length), got {len(est)} and {len(gt)}")
    if method == "none":
        R, t, s = np.eye(3), np.zeros(3), 1.0
    elif method == "first":
        T_gt_est = gt.T[0] @ inv_T(est.T[0])
        R, t, s = T_gt_est[:3, :3], T_gt_est[:3, 3], 1.0
    elif method == "posyaw":
        R, t, s = _posyaw(est.positions, gt.positions)
    else:
        R, t, s = umeyama(est.positions, gt.positions, with_scale=(method == "sim3"))
    return apply_alignment(est, R, t, s), AlignInfo(np.asarray(R), np.asarray(t), float(s), method)
