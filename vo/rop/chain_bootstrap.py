"""Bootstrap over track identities along the trajectory (``rop`` ``cov="chain_bootstrap"``; our extension).

Why: per keyframe step the track bootstrap of :mod:`vo.rop.bootstrap_cov` is right on rendered
sequences (campus-short, 30 scenes at 3x rendering, 390 keyframe steps: per-axis std of the step
error over its bootstrap std 0.88-1.05, docs/studies/step_correlation.py), but summing independent
step covariances is not: consecutive keyframe steps' errors correlate (lag-1 correlation 0.13-0.44
per axis, lag-2 up to 0.31; docs/studies/rop_consistency.md). A track outlives a keyframe (its
current ``p3, p4`` become the next keyframe's ``p1, p2``, :mod:`vo.rop.tracks`) and what is wrong
with it (texture, rendering, LK window bias) stays wrong, so one feature set pushes several steps the
same way.

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

Between keyframes (:class:`ChainBootstrap`) the frame's covariance is the first-order step covariance
scaled per axis by the last bootstrap's std ratio, chained onto the keyframe's
(:func:`vo.rop.uncertainty.propagate_cov`). Until the first keyframe step is chained the step
covariance is the whole covariance, and the bootstrap / first-order ratio changes as the parallax
grows from < 1 px: the step is bootstrapped again each time it has doubled in length (about 3 extra
per run). Rotation-only epochs keep their first-order covariance. Cost: about 1 s per keyframe at 40
replicates.
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import pose_error_cov, so3_exp
from vo.errors import EstimatorError
from vo.rop.bootstrap_cov import MIN_REPLICATES, bootstrap_step_replicates, replicate_cov
from vo.rop.uncertainty import Step, propagate_cov


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


class ChainBootstrap:
    """The :class:`~vo.rop.uncertainty.UncertaintyModel` of ``cov="chain_bootstrap"`` (module docstring).

    ``config`` the estimator's :class:`~vo.rop.rop_config.RopConfig` (RANSAC options, ``seed``,
    ``bootstrap_replicates``), ``adjustment_config`` its :class:`~vo.rop.adjustment.AdjustmentConfig`,
    ``focal`` (px) to turn the pixel gate into normalized units. Every draw is seeded by ``seed`` (and
    the frame's ``t_ns`` for the RANSAC of the replicates), so a rerun gives the same bytes."""

    def __init__(self, config, adjustment_config, focal: float):
        self.config, self.adjustment_config, self.focal = config, adjustment_config, float(focal)
        self.chain = ReplicateChain(config.bootstrap_replicates, np.random.default_rng([int(config.seed), 0xC4A1]))
        self._scale = None          # per-axis std ratio bootstrap / first order at the last bootstrap
        self._length = None         # step length (m) at the last bootstrap
        self._chained = False       # a keyframe step has been chained (start-up is over)

    def on_step(self, step: Step) -> np.ndarray:
        cov_step, reps = self.step_cov(step)
        cov = propagate_cov(step.cov_kf, step.T_o_kf, step.T_kf_c, cov_step)
        self._chained |= step.keyframe
        if step.keyframe:
            cov = self.chain.step(step.T_kf_c, reps, cov_step, step.T_o_c)
        return cov

    def reset(self, T_o_c: np.ndarray, cov: np.ndarray) -> None:
        self.chain.reset(T_o_c, cov)

    def step_cov(self, step: Step) -> tuple:
        """-> ``(cov_step, replicates or None)``: the bootstrap at keyframe steps, at the first ROP epoch
        and during start-up (:meth:`_startup_due`); else the first-order ``cov_step`` scaled per axis
        by the last bootstrap's std ratio (``D C D``)."""
        if step.ropset is None:
            return step.cov_step, None
        if step.keyframe or self._scale is None or self._startup_due(step.T_kf_c):
            reps = self.replicates(step)
            C = replicate_cov(reps, step.T_kf_c)
            if C is None:
                return step.cov_step, None
            d = np.sqrt(np.maximum(np.diag(step.cov_step), 1e-300))
            self._scale = np.sqrt(np.diag(C)) / d
            self._length = float(np.linalg.norm(step.T_kf_c[:3, 3]))
            return C, reps
        D = np.diag(self._scale)
        return D @ step.cov_step @ D, None

    def replicates(self, step: Step) -> list:
        """The step's replicates (:func:`vo.rop.bootstrap_cov.bootstrap_step_replicates`): with KLT tracks,
        at keyframe steps, by the tracks' kept multiplicities; otherwise fresh draws."""
        tracks = step.tracks
        counts = self.chain.counts(tracks.ids) if tracks is not None and step.keyframe else None
        return bootstrap_step_replicates(step.ropset, step.pairs, tracks.ok4 if tracks is not None else None, counts,
                                         n_boot=self.config.bootstrap_replicates, **self.solver_options(step))

    def solver_options(self, step: Step) -> dict:
        """Keyword arguments of :func:`vo.rop.bootstrap_cov.replicate_step` for this step: the
        adjustment, a generator seeded by ``(seed, t_ns)``, the estimator's gates and RANSAC options."""
        c = self.config
        return dict(config=self.adjustment_config, rng=np.random.default_rng([int(c.seed), int(step.t_ns)]),
                    threshold=c.ransac_threshold_px / self.focal, min_inliers=c.min_rop_inliers,
                    ransac=dict(max_iters=c.ransac_max_iters, prob=c.ransac_prob,
                                loss=c.rop_loss))

    def _startup_due(self, T_kf_c: np.ndarray) -> bool:
        """Before the first keyframe step is chained: bootstrap again once the step has doubled in length."""
        return not self._chained and self._length is not None and \
            float(np.linalg.norm(T_kf_c[:3, 3])) >= 2.0 * max(self._length, 1e-6)
