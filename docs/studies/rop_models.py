"""Covariance models of ``rop`` that were studied and are not in the product (docs/studies/rop_consistency.md).

Each is an :class:`vo.rop.uncertainty.UncertaintyModel` plugged in through
``RopEstimator(rig, config, uncertainty=model)``, and each has an estimator class, so the CLI runs it by
class path from the repository root (``PYTHONPATH=.``), e.g.

    PYTHONPATH=. .venv/bin/vo-testbed consistency --scenario campus-short --runs 30 --workers 2 \
        --estimator docs.studies.rop_models:RopNoiseChain --set render.supersample=3 \
        --opt 'klt_config={win: 11}' --out D

* :class:`RopBootstrap`: the track bootstrap of every keyframe step
  (:mod:`vo.rop.bootstrap_cov`), steps chained as independent. Superseded by ``cov=chain_bootstrap``,
  which keeps the correlation of consecutive steps.
* :class:`RopAposteriori`: the adjustment's a-posteriori covariance (unit-weight
  variance from the disagreement of the four ROPs) as the step covariance.
* :class:`RopNoiseChain`: a parametric bootstrap of the image noise
  along the keyframe chain, below.

Noise chain. What it predicts: the spread of the estimate when only the image noise changes. Each
image's noise moves the LK solution at a track's point in that image by a *footprint*
``a ~ N(0, C)`` (:func:`vo.frontend.lk_noise.lk_noise_cov`, ``C = sigma^2 A^-1 H A^-T``), independent
between images and tracks; an LK from image A to B errs by ``a_B - a_A``. The four-view tracks of
:mod:`vo.rop.tracks` are chains of such LKs (``p2`` stereo from ``p1``; ``p3`` frame to frame from
``p1``, the intermediate frames' footprints cancelling to first order; ``p4`` stereo from ``p3``), so
perturbing every view by its own footprint, ``p_k + a_k``, reproduces all four relative errors. A
keyframe's images are views 3, 4 of the step that ends there and views 1, 2 of the next: a track keeps
those footprints (per replicate) across the keyframe. Per replicate ``b`` at a keyframe step: perturb
the tracks, re-solve the step (:func:`vo.rop.bootstrap_cov.replicate_step`), compose it onto the
replicate's keyframe pose. ``image_noise_sigma`` (grey levels) or estimated from the images
(:func:`vo.frontend.noise_level.estimate_noise_sigma`).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from vo.errors import EstimatorError
from vo.frontend.lk_noise import lk_noise_cov
from vo.frontend.noise_level import estimate_noise_sigma
from vo.rop.bootstrap_cov import bootstrap_step_replicates, replicate_step
from vo.rop.chain_bootstrap import ChainBootstrap, ReplicateChain
from vo.rop.rop_config import RopConfig
from vo.rop.estimator import RopEstimator
from vo.rop.uncertainty import Step, propagate_cov

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


class IndependentBootstrap(ChainBootstrap):
    """Fresh track draws per keyframe step, steps chained as independent (:func:`propagate_cov`)."""

    def on_step(self, step: Step) -> np.ndarray:
        cov_step, _ = self.step_cov(step)
        self._chained |= step.keyframe
        return propagate_cov(step.cov_kf, step.T_o_kf, step.T_kf_c, cov_step)

    def replicates(self, step: Step) -> list:
        tracks = step.tracks
        return bootstrap_step_replicates(step.ropset, step.pairs, tracks.ok4 if tracks is not None else None, None,
                                         n_boot=self.config.bootstrap_replicates, **self.solver_options(step))


class Aposteriori:
    """The adjustment's a-posteriori covariance as the step covariance (first order otherwise)."""

    def on_step(self, step: Step) -> np.ndarray:
        apost = step.adjustment.cov_apost if step.adjustment is not None else None
        return propagate_cov(step.cov_kf, step.T_o_kf, step.T_kf_c, step.cov_step if apost is None else apost)

    def reset(self, T_o_c: np.ndarray, cov: np.ndarray) -> None:
        pass


class NoiseChainModel(ChainBootstrap):
    """The noise chain (module docstring) on the KLT four-view tracks; ``normalize(p, camera)`` and ``win``
    those of the estimator's :class:`vo.rop.tracks.KltFourView`."""

    def __init__(self, config, adjustment_config, focal: float, normalize, win: int, sigma=None):
        super().__init__(config, adjustment_config, focal)
        if sigma is not None and (isinstance(sigma, bool) or not isinstance(sigma, (int, float))
                                  or not np.isfinite(sigma) or sigma < 0):
            raise EstimatorError(f"rop.image_noise_sigma: {sigma!r}; must be None (estimated) or a finite number >= 0")
        self.chain = NoiseChain(config.bootstrap_replicates, np.random.default_rng([int(config.seed), 0xC4A1]))
        self.normalize, self.win, self.sigma = normalize, int(win), sigma

    def replicates(self, step: Step) -> list:
        view = step.tracks
        offsets = self.chain.offsets(view.ids, self.footprint_covs(step))
        if step.keyframe:
            self.chain.commit()
        return noise_step_replicates(step.ropset, view, offsets, self.normalize, **self.solver_options(step))

    def footprint_covs(self, step: Step) -> np.ndarray:
        """(N,4,2,2) footprint covariances of the tracks in views 1-4 (keyframe left/right, current left/right)."""
        view = step.tracks
        sigma = estimate_noise_sigma(step.images[2]) if self.sigma is None else self.sigma
        p4 = np.where(view.ok4[:, None], view.p4, view.p3)
        return np.stack([lk_noise_cov(img, p, self.win, sigma)
                         for img, p in zip(step.images, (view.p1, view.p2, view.p3, p4))], 1)


class RopBootstrap(RopEstimator):
    """``rop`` with :class:`IndependentBootstrap` (options: those of :class:`vo.rop.rop_config.RopConfig`)."""

    name = "rop-bootstrap"

    def __init__(self, rig, **options):
        super().__init__(rig, RopConfig.from_options(options))
        self.uncertainty = IndependentBootstrap(self.config, self.adjustment_config, self.focal)


class RecordingBootstrap(RopEstimator):
    """``rop`` with :class:`IndependentBootstrap` that also keeps each keyframe step's covariance
    (``uncertainty.step_covs``: ``t_ns`` -> (6, 6); docs/studies/step_correlation.py)."""

    name = "rop-bootstrap-recording"

    def __init__(self, rig, **options):
        super().__init__(rig, RopConfig.from_options(options))
        self.uncertainty = _Recording(self.config, self.adjustment_config, self.focal)


class _Recording(IndependentBootstrap):
    def __init__(self, *args):
        super().__init__(*args)
        self.step_covs = {}

    def step_cov(self, step: Step) -> tuple:
        out = super().step_cov(step)
        self.step_covs[step.t_ns] = out[0]
        return out


class RopAposteriori(RopEstimator):
    """``rop`` with :class:`Aposteriori`."""

    name = "rop-apost"

    def __init__(self, rig, **options):
        super().__init__(rig, RopConfig.from_options(options), uncertainty=Aposteriori())


class RopNoiseChain(RopEstimator):
    """``rop`` with :class:`NoiseChainModel`; KLT front-end only; ``image_noise_sigma`` grey levels or None."""

    name = "rop-noise-chain"

    def __init__(self, rig, image_noise_sigma=None, **options):
        super().__init__(rig, RopConfig.from_options(options))
        if self.klt is None:
            raise EstimatorError(f"rop.frontend: {self.config.frontend!r}; the noise chain needs 'klt' (LK footprints)")
        self.uncertainty = NoiseChainModel(self.config, self.adjustment_config, self.focal, self.klt.normalize,
                                           self.config.klt_config.win, image_noise_sigma)
