"""Bootstrap covariance of one adjusted ROP step over the epoch's four-view tracks (our extension).

Why: the first-order models (:mod:`vo.rop.propagation`, :mod:`vo.rop.joint_cov`) propagate an
isotropic, independent pixel noise through a fixed inlier set. On rendered sequences the
run-to-run error of a step is dominated by something else (docs/consistency.md): which tracks
exist and which are inliers changes between noise realisations, and every track carries its own
rendering / tracking error that is the same in every run, so a new feature set moves the solution
like a resampling of those per-feature errors (heavy-tailed, heteroscedastic, shared by the
ROPs of one track). A nonparametric bootstrap over tracks (Efron & Tibshirani 1993, ch. 6, the
"bootstrapping pairs" scheme for regression; the resampling unit is the four-view track, so the
correlation of the four ROPs through shared points is kept) estimates exactly that spread.

Per replicate ``b``: draw ``N`` track indices with replacement (``rng``, one explicit generator);
for each usable ROP re-estimate it from its matches of the drawn tracks with
:func:`vo.rop.relative.estimate_rop_normalized` (RANSAC with a seed drawn from ``rng``, the epoch's
solution as the disambiguation prior, Sampson LM, inlier re-selection): RANSAC and inlier decisions
are part of the spread (an LM-only refit from the epoch's solution stayed 2x under the Monte-Carlo
z-spread on campus-short); then the initial EOPs and the two-step adjustment, unchanged. The
covariance is that of ``[log(R_b R_hat^T), t_b - t_hat]`` over the replicates (left perturbation,
the convention of :func:`vo.rop.estimator.propagate_cov`), about the replicates' mean, ddof 1.
"""
from __future__ import annotations

import numpy as np

from vo.geometry import pose_error_left
from vo.rop.adjustment import AdjustmentConfig, adjust_rops
from vo.rop.initial import initial_eops
from vo.rop.relative import estimate_rop_normalized
from vo.rop.ropset import RopSet

MIN_REPLICATES = 8


def _resampled_rop(m, x_i: np.ndarray, x_j: np.ndarray, thr: float, min_inliers: int, ransac: dict):
    """The ROP ``m`` re-estimated from the matches ``x_i``, ``x_j`` (a bootstrap draw), or None."""
    f = estimate_rop_normalized(x_i, x_j, 1.0 / thr, ransac_threshold_px=1.0, min_inliers=min_inliers,
                                prior=(m.R_i_j, m.rhat_i_j), **ransac)
    return f if f.ok else None


def _draw_rows(rng: np.random.Generator, ok4, sizes: dict) -> dict:
    """pair -> row indices of one bootstrap draw. Shared tracks (``ok4`` (N,) bool given): N track
    indices with replacement, mapped to each pair's rows (pairs 13 / 23 hold all tracks, 14 / 24 the
    ``ok4`` subset), so a drawn track enters all its ROPs. ``ok4`` None (descriptor front-ends, one
    match set per pair): each pair's matches are drawn independently."""
    if ok4 is None:
        return {p: rng.integers(0, n, n) for p, n in sizes.items()}
    idx = rng.integers(0, len(ok4), len(ok4))
    pos4 = np.cumsum(ok4) - 1                              # track index -> row of the 14 / 24 arrays
    return {p: (pos4[idx[ok4[idx]]] if p[1] == "4" else idx) for p in sizes}


def bootstrap_step_cov(ropset: RopSet, tracks: dict, ok4, T_c1_c3: np.ndarray, config: AdjustmentConfig,
                       rng: np.random.Generator, n_boot: int = 40, threshold: float = 1.0 / 500,
                       min_inliers: int = 20, ransac: dict = None):
    """(6,6) bootstrap covariance of ``[rotvec, position]`` of the adjusted ``T_c1_c3``, or None.

    ``tracks``: pair -> ``(x_i, x_j)`` normalized matches as the estimator used them
    (:meth:`vo.rop.tracks.FourView.pair`); ``ok4`` see :func:`_draw_rows`; ``threshold`` the inlier
    gate in normalized units; ``ransac`` keyword arguments of
    :func:`vo.rop.relative.estimate_rop_normalized` (``max_iters``, ``prob``, ``method``; None: its
    defaults), its RANSAC repeated per replicate with a seed drawn from ``rng``. None when fewer than
    :data:`MIN_REPLICATES` of ``n_boot`` replicates give >= 3 ROPs and a non-degenerate adjustment."""
    errors = []
    sizes = {p: len(tracks[p][0]) for p in ropset.ok_pairs}
    for _ in range(int(n_boot)):
        rows = _draw_rows(rng, ok4, sizes)
        rops = {}
        for p in ropset.ok_pairs:
            x_i, x_j = tracks[p]
            opts = {**(ransac or {}), "seed": int(rng.integers(2 ** 31))}
            fit = _resampled_rop(ropset.rops[p], x_i[rows[p]], x_j[rows[p]], threshold, min_inliers, opts)
            if fit is not None:
                rops[p] = fit
        if len(rops) < 3:
            continue
        rs = RopSet(rops, ropset.T_c1_c2, ropset.weighting)
        res = adjust_rops(rs, initial_eops(rs), config)
        if res.degenerate or not np.all(np.isfinite(res.T_c1_c3)):
            continue
        errors.append(pose_error_left(res.T_c1_c3, T_c1_c3))
    if len(errors) < MIN_REPLICATES:
        return None
    return np.cov(np.array(errors), rowvar=False, ddof=1)
