"""Bootstrap over track identities along the trajectory (``rop`` ``cov="chain_bootstrap"``; our extension).

Why: per keyframe step the track bootstrap of :mod:`vo.rop.bootstrap_cov` is right on rendered
sequences (campus-short, 30 scenes at 3x rendering, 390 keyframe steps: per-axis std of the step
error over its bootstrap std 0.88-1.05, docs/scripts/step_correlation.py), but summing independent step covariances is not:
consecutive keyframe steps' errors correlate (lag-1 correlation 0.13-0.44 per axis, lag-2 up to
0.31; docs/consistency.md). A track outlives a keyframe (its current ``p3, p4`` become the next
keyframe's ``p1, p2``, :mod:`vo.rop.tracks`) and what is wrong with it (texture, rendering, LK
window bias) stays wrong, so one feature set pushes several steps the same way.

Scheme: ``B`` replicate trajectories. Each track identity gets one Poisson(1) multiplicity per
replicate when it is first used, kept for the track's life (the Poisson bootstrap, which lets new
tracks join a running resample: Oza & Russell 2001, "Online bagging and boosting"; Hanley &
MacGibbon 2006), so a replicate that over-weights a track does so in every step the track enters.
At each keyframe step replicate ``b`` re-solves the step from its weighted tracks (RANSAC, ROPs,
adjustment: :func:`vo.rop.bootstrap_cov.bootstrap_step_replicates`) and composes it onto its own
keyframe pose, ``T_o_kf'(b) = T_o_kf(b) T_kf_kf'(b)``; the keyframe covariance is that of
``pose_error_left(T_o_kf'(b), T_o_kf')`` over the replicates (about their mean, ddof 1). A step with
no replicates (rotation-only epoch, too few successful replicates) or a failed replicate enters as a
draw ``exp(xi) T``, ``xi ~ N(0, cov_step)`` (left perturbation, ``[rotvec, position]``).
"""
from __future__ import annotations

import numpy as np

from vo.errors import EstimatorError
from rigs.geometry import pose_error_cov, so3_exp
from vo.rop.bootstrap_cov import MIN_REPLICATES


def gaussian_pose_draws(T: np.ndarray, cov: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n,4,4) poses ``exp(xi) T`` with ``xi ~ N(0, cov)`` (6,6), ``[rotvec, position]`` left perturbation."""
    w, V = np.linalg.eigh(0.5 * (cov + cov.T))
    xi = rng.standard_normal((n, 6)) @ (V * np.sqrt(np.clip(w, 0.0, None))).T
    out = np.tile(np.asarray(T, float), (n, 1, 1))
    out[:, :3, :3] = so3_exp(xi[:, :3]).reshape(n, 3, 3) @ T[:3, :3]
    out[:, :3, 3] = T[:3, 3] + xi[:, 3:]
    return out


class ReplicateChain:
    """``n`` replicate keyframe poses ``T`` (n,4,4) in ``O`` and the per-track Poisson multiplicities.

    ``rng``: the one generator of all draws (multiplicities, Gaussian steps), so a rerun gives the same bytes."""

    def __init__(self, n: int, rng: np.random.Generator):
        if n < MIN_REPLICATES:
            raise EstimatorError(f"rop.bootstrap_replicates: {n!r}; must be an integer >= {MIN_REPLICATES}")
        self.n, self.rng = int(n), rng
        self.T = np.tile(np.eye(4), (self.n, 1, 1))
        self._counts: dict[int, np.ndarray] = {}

    def counts(self, ids: np.ndarray) -> np.ndarray:
        """(n, N) multiplicities of the tracks ``ids`` (N,): drawn on first use, then fixed. Identities
        not in ``ids`` are forgotten (a lost track never comes back)."""
        ids = [int(i) for i in ids]
        new = [i for i in ids if i not in self._counts]
        draws = self.rng.poisson(1.0, (len(new), self.n))
        kept = {i: self._counts[i] for i in ids if i in self._counts}
        kept.update(zip(new, draws))
        self._counts = kept
        return np.array([kept[i] for i in ids]).reshape(len(ids), self.n).T

    def step(self, T_step: np.ndarray, replicates, cov_step: np.ndarray, T_hat: np.ndarray) -> np.ndarray:
        """Compose every replicate with its own step: its entry of ``replicates`` (list of n (4,4) or
        None; the list None: no replicates) or a Gaussian draw of ``cov_step`` about ``T_step`` (4,4).
        -> (6,6) covariance of the new keyframe pose ``T_hat`` (4,4) (:meth:`cov` of the replicates)."""
        draws = gaussian_pose_draws(T_step, cov_step, self.n, self.rng)
        if replicates is not None:
            for b, T_b in enumerate(replicates):
                if T_b is not None:
                    draws[b] = T_b
        self.T = self.T @ draws
        return self.cov(self.T, T_hat)

    @staticmethod
    def cov(T_reps: np.ndarray, T_hat: np.ndarray) -> np.ndarray:
        """(6,6) covariance of ``pose_error_left(T_reps[b], T_hat)`` over the replicates (ddof 1)."""
        return pose_error_cov(T_reps, T_hat)

    def reset(self, T_hat: np.ndarray, cov: np.ndarray) -> None:
        """Restart the replicates as Gaussian draws about ``T_hat`` (after a failed frame: the tracks
        and their multiplicities are gone)."""
        self.T = gaussian_pose_draws(T_hat, cov, self.n, self.rng)
        self._counts = {}
