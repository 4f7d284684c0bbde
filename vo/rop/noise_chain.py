"""Parametric bootstrap of the image noise along the keyframe chain (``rop`` ``cov="noise_chain"``; our extension).

What it predicts: the spread of the estimate when only the image noise changes - the Monte-Carlo
protocol that renders once and re-noises the images per run (docs/consistency.md). The track
bootstrap (:mod:`vo.rop.chain_bootstrap`) resamples the tracks' own errors, which on rendered images
are mostly static (texture, rendering, LK window bias: the same in every noise realisation), so it
predicts the error over scenes, about twice the noise-only spread.

Model. Each image's noise moves the LK solution at a track's point in that image by a *footprint*
``a ~ N(0, C)`` (:func:`vo.frontend.lk_noise.lk_noise_cov`, ``C = sigma^2 A^-1 H A^-T``), independent
between images and tracks; an LK from image A to B errs by ``a_B - a_A``. The four-view tracks of
:mod:`vo.rop.tracks` are chains of such LKs: ``p2`` = stereo LK from ``p1``; ``p3`` = frame-to-frame
LKs from ``p1`` (the intermediate frames' footprints cancel to first order: each is the target of one
LK and the template of the next at the same point); ``p4`` = stereo LK from ``p3``. So relative to the
point ``p1`` marks, ``p_k`` errs by ``a_k - a_1`` and perturbing every view by its own footprint,
``p_k + a_k``, reproduces all four relative errors. A keyframe's images are views 3, 4 of the step that
ends there and views 1, 2 of the next: a track keeps those footprints (per replicate) across the
keyframe, which makes consecutive steps' errors anti-correlated through the shared image noise.

Per replicate ``b`` at a keyframe step: perturb the tracks by the replicate's footprints, re-solve
the step (RANSAC, ROPs, adjustment: :func:`vo.rop.bootstrap_cov.replicate_step`), compose it onto the
replicate's keyframe pose (:class:`~vo.rop.chain_bootstrap.ReplicateChain`). ``sigma`` comes from the
``image_noise_sigma`` option or from the images (:func:`vo.frontend.noise_level.estimate_noise_sigma`).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from vo.rop.bootstrap_cov import replicate_step
from vo.rop.chain_bootstrap import ReplicateChain

VIEW_CAMERA = (0, 1, 0, 1)       # views 1-4 -> camera (left, right, left, right)


def draw_footprints(cov: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, N, 2) draws of ``N(0, cov[i])``, ``cov`` (N,2,2) (px^2); non-finite covariances give 0."""
    cov = np.asarray(cov, float).reshape(-1, 2, 2)
    good = np.all(np.isfinite(cov), axis=(1, 2))
    L = np.zeros_like(cov)
    if good.any():
        w, V = np.linalg.eigh(0.5 * (cov[good] + np.swapaxes(cov[good], 1, 2)))
        L[good] = V * np.sqrt(np.clip(w, 0.0, None))[:, None, :]
    return np.einsum("nij,bnj->bni", L, rng.standard_normal((n, len(cov), 2)))


class NoiseChain(ReplicateChain):
    """``n`` replicate keyframe poses and, per track identity, its footprints in the keyframe's left
    and right images (n,2,2) ``[replicate, side, xy]``. ``rng`` the one generator of all draws."""

    def __init__(self, n: int, rng: np.random.Generator):
        super().__init__(n, rng)
        self._kf: dict[int, np.ndarray] = {}
        self._pending: dict[int, np.ndarray] = {}

    def offsets(self, ids: np.ndarray, cov: np.ndarray) -> np.ndarray:
        """(n, N, 4, 2) pixel offsets of the tracks ``ids`` (N,) in views 1-4. ``cov`` (N,4,2,2): each
        view's footprint covariance. Views 1, 2 reuse the footprints a track got when its keyframe was
        the current frame (drawn now for tracks new at the keyframe, then kept); views 3, 4 are new
        draws, kept by :meth:`commit`. Identities not in ``ids`` are forgotten."""
        ids = [int(i) for i in ids]
        cov = np.asarray(cov, float).reshape(len(ids), 4, 2, 2)
        new = [k for k, i in enumerate(ids) if i not in self._kf]
        kf = {i: self._kf[i] for i in ids if i in self._kf}
        if new:
            d = np.stack([draw_footprints(cov[new, s], self.n, self.rng) for s in (0, 1)], 2)   # (n, M, 2, 2)
            kf.update((ids[k], d[:, m]) for m, k in enumerate(new))
        self._kf = kf
        cur = np.stack([draw_footprints(cov[:, s], self.n, self.rng) for s in (2, 3)], 2)      # (n, N, 2, 2)
        self._pending = {i: cur[:, k] for k, i in enumerate(ids)}
        first = np.stack([kf[i] for i in ids], 1).reshape(self.n, len(ids), 2, 2)
        return np.concatenate([first, cur], axis=2)

    def commit(self) -> None:
        """The current frame becomes the keyframe: its footprints become the tracks' views 1, 2."""
        self._kf, self._pending = self._pending, {}

    def reset(self, T_hat: np.ndarray, cov: np.ndarray) -> None:
        super().reset(T_hat, cov)
        self._kf, self._pending = {}, {}


def noise_step_replicates(ropset, view, offsets: np.ndarray, normalize, config, rng: np.random.Generator,
                          threshold: float, min_inliers: int, ransac: dict | None) -> list:
    """Adjusted ``T_c1_c3`` (4,4) of each replicate (None where it fails): the four-view tracks ``view``
    (:class:`vo.rop.tracks.FourView`) with pixels ``p_k + offsets[b, :, k]`` ((n,N,4,2)), normalized by
    ``normalize(p, camera)``, re-solved by :func:`vo.rop.bootstrap_cov.replicate_step`."""
    p, ok4 = (view.p1, view.p2, view.p3, view.p4), view.ok4
    out = []
    for off in offsets:
        x = [normalize(p[k] + off[:, k], VIEW_CAMERA[k]) for k in range(3)]
        x4 = np.zeros_like(view.x4)
        x4[ok4] = normalize(p[3][ok4] + off[ok4, 3], 1)
        moved = dataclasses.replace(view, x1=x[0], x2=x[1], x3=x[2], x4=x4)
        pairs = {q: moved.pair(q) for q in ropset.ok_pairs}
        rows = {q: np.arange(len(pairs[q][0])) for q in pairs}
        out.append(replicate_step(ropset, pairs, rows, config, rng, threshold, min_inliers, ransac))
    return out
