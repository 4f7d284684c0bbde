"""Bootstrap covariance of one adjusted ROP step over the epoch's four-view tracks (our extension).

Why: the first-order model (:mod:`vo.rop.propagation`) propagates an
isotropic, independent pixel noise through a fixed inlier set. On rendered sequences the
run-to-run error of a step is dominated by something else (docs/studies/rop_consistency.md): which tracks
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

from rigs.geometry import pose_error_cov
from vo.rop.adjustment import AdjustmentConfig, adjust_rops
from vo.rop.initial_eops import initial_eops
from vo.rop.relative import estimate_rop_normalized
from vo.rop.ropset import RopSet

MIN_REPLICATES = 8


def _resampled_rop(m, x_i: np.ndarray, x_j: np.ndarray, thr: float, min_inliers: int, ransac: dict):
    """The ROP ``m`` re-estimated from the matches ``x_i``, ``x_j`` (a bootstrap draw), or None."""
    f = estimate_rop_normalized(x_i, x_j, 1.0 / thr, ransac_threshold_px=1.0, min_inliers=min_inliers,
                                prior=(m.R_i_j, m.rhat_i_j), **ransac)
    return f if f.ok else None


def _rows_of(idx: np.ndarray, ok4, sizes: dict) -> dict:
    """pair -> row indices of one bootstrap draw given the drawn track indices ``idx`` (with
    repeats): pairs 13 / 23 hold all tracks, 14 / 24 the ``ok4`` subset, so a drawn track enters all
    its ROPs."""
    pos4 = np.cumsum(ok4) - 1                              # track index -> row of the 14 / 24 arrays
    return {p: (pos4[idx[ok4[idx]]] if p[1] == "4" else idx) for p in sizes}


def _draw_rows(rng: np.random.Generator, ok4, sizes: dict) -> dict:
    """pair -> row indices of one bootstrap draw. Shared tracks (``ok4`` (N,) bool given): N track
    indices with replacement (:func:`_rows_of`). ``ok4`` None (descriptor front-ends, one match set
    per pair): each pair's matches are drawn independently."""
    if ok4 is None:
        return {p: rng.integers(0, n, n) for p, n in sizes.items()}
    return _rows_of(rng.integers(0, len(ok4), len(ok4)), ok4, sizes)


def replicate_step(ropset: RopSet, tracks: dict, rows: dict, config: AdjustmentConfig, rng: np.random.Generator,
               threshold: float, min_inliers: int, ransac: dict | None):
    """Adjusted ``T_c1_c3`` (4,4) of one bootstrap draw ``rows`` (pair -> row indices), or None when
    fewer than 3 ROPs survive or the adjustment degenerates."""
    rops = {}
    for p in ropset.ok_pairs:
        x_i, x_j = tracks[p]
        opts = {**(ransac or {}), "seed": int(rng.integers(2 ** 31))}
        fit = _resampled_rop(ropset.rops[p], x_i[rows[p]], x_j[rows[p]], threshold, min_inliers, opts)
        if fit is not None:
            rops[p] = fit
    if len(rops) < 3:
        return None
    rs = RopSet(rops, ropset.T_c1_c2, ropset.weighting)
    res = adjust_rops(rs, initial_eops(rs), config)
    if res.degenerate or not np.all(np.isfinite(res.T_c1_c3)):
        return None
    return res.T_c1_c3


def bootstrap_step_cov(ropset: RopSet, tracks: dict, ok4, T_c1_c3: np.ndarray, config: AdjustmentConfig,
                       rng: np.random.Generator, n_boot: int = 40, threshold: float = 1.0 / 500,
                       min_inliers: int = 20, ransac: dict = None):
    """(6,6) bootstrap covariance of ``[rotvec, position]`` of the adjusted ``T_c1_c3``, or None.

    ``tracks``: pair -> ``(x_i, x_j)`` normalized matches as the estimator used them
    (:meth:`vo.rop.tracks.FourView.pair`); ``ok4`` see :func:`_draw_rows`; ``threshold`` the inlier
    gate in normalized units; ``ransac`` keyword arguments of
    :func:`vo.rop.relative.estimate_rop_normalized` (``max_iters``, ``prob``, ``loss``; None: its
    defaults), its RANSAC repeated per replicate with a seed drawn from ``rng``. None when fewer than
    :data:`MIN_REPLICATES` of ``n_boot`` replicates give >= 3 ROPs and a non-degenerate adjustment."""
    reps = bootstrap_step_replicates(ropset, tracks, ok4, None, config, rng, n_boot, threshold, min_inliers, ransac)
    return replicate_cov(reps, T_c1_c3)


def bootstrap_step_replicates(ropset: RopSet, tracks: dict, ok4, counts, config: AdjustmentConfig,
                              rng: np.random.Generator, n_boot: int = 40, threshold: float = 1.0 / 500,
                              min_inliers: int = 20, ransac: dict = None) -> list:
    """Adjusted ``T_c1_c3`` of each bootstrap replicate: list of (4,4) arrays, None for a failed one
    (:func:`replicate_step`). ``counts`` (B,N) integers: replicate ``b`` takes track ``i`` ``counts[b, i]``
    times (e.g. Poisson(1) multiplicities kept per track identity, :mod:`vo.rop.chain_bootstrap`;
    needs ``ok4``); None: ``n_boot`` draws of :func:`_draw_rows`. Other arguments as
    :func:`bootstrap_step_cov`."""
    sizes = {p: len(tracks[p][0]) for p in ropset.ok_pairs}
    if counts is None:
        draws = (_draw_rows(rng, ok4, sizes) for _ in range(int(n_boot)))
    else:
        base = np.arange(len(ok4))
        draws = (_rows_of(np.repeat(base, c), ok4, sizes) for c in np.asarray(counts, int))
    return [replicate_step(ropset, tracks, rows, config, rng, threshold, min_inliers, ransac) for rows in draws]


def replicate_cov(replicates: list, T_ref: np.ndarray):
    """(6,6) covariance (ddof 1, about the replicates' mean) of ``pose_error_left(T_b, T_ref)`` over the
    replicates that are not None, or None when fewer than :data:`MIN_REPLICATES`."""
    valid = [T for T in replicates if T is not None]
    if len(valid) < MIN_REPLICATES:
        return None
    return pose_error_cov(np.array(valid), T_ref)
