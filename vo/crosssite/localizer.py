"""The cross-site localizer (seed 001 §2): site k against site k-1, whose pose is held fixed.

Stages 1-5 (:mod:`vo.crosssite.ties`) give tie points; stage 6 the initial values (space
intersection at the previous site, resection at the current one, eq. 3); stage 7 the bundle
adjustment (:mod:`vo.crosssite.bundle`). Without tie points (``no_tie_points``) or with fewer than
``min_tie_points`` after the outlier test or fewer than ``min_ba_ties`` agreeing with the resection
(a small set can hold false matches the BA absorbs: its points slide along their rays), a failed
resection/BA, or a BA pose farther from the prior
than ``prior_gate_chi2`` (a periodic texture can give a consistent wrong solution) (``few_tie_points``), or a
tie set that holds a second self-consistent motion (:func:`second_motion`, ``ambiguous``) the
dead-reckoning pose is kept and its covariance multiplied by ``inflate``: never an exception or NaN
for data that merely do not match.
"""
from __future__ import annotations

import dataclasses
import time
from typing import Optional, Sequence

import numpy as np

from rigs.geometry import inv_T
from vo.crosssite.asift import DetectionCache
from vo.crosssite.bundle import TieObservations, bundle_adjust
from vo.crosssite.localizer_config import CrossSiteConfig
from vo.crosssite.intersect_resect import resection
from vo.crosssite.ties import TieSet, body_points, candidate_ties, refine_cross_site, stereo_and_consistency
from vo.crosssite.types import Site, SiteResult


def _fallback(cur: Site, status: str, cfg, ties: Optional[TieSet], reason: str, timings) -> SiteResult:
    return SiteResult(cur.index, status, cur.T_w_b_prior.copy(), cur.cov_prior * cfg.inflate,
                      int(ties.inlier.sum()) if ties is not None and ties.inlier is not None else 0,
                      dict(ties.stats) if ties is not None else {}, timings, reason, ties)


def initial_pose(cur: Site, T_w_b_prev, prev: Site, ties: TieSet, idx, cfg) -> tuple:
    """Stage 6: tie points in w by intersection at the previous site, then :func:`best_resection`.
    -> (T_w_b initial, P_w (n,3))."""
    K, B = cur.cal.K, cur.cal.baseline
    P_b, _ = body_points(prev, ties.pair_prev[idx], ties.uv_prev[idx], ties.ur_prev[idx], K, B)
    P_w = P_b @ T_w_b_prev[:3, :3].T + T_w_b_prev[:3, 3]
    return best_resection(cur, P_w, ties, idx, cfg), P_w


def best_resection(cur: Site, P_w, ties: TieSet, idx, cfg) -> np.ndarray:
    """Resection of each current left image that sees >= ``min_tie_points`` of the points ``P_w``
    (n,3) of ties ``idx``; the pair with most inliers gives ``T_w_b`` (4,4); the prior when every
    resection fails."""
    best, T_best = 0, None
    for j in np.unique(ties.pair_cur[idx]):
        s = ties.pair_cur[idx] == j
        if s.sum() < cfg.min_tie_points:
            continue
        T_b_c0 = cur.pairs[j].T_b_c0
        r = resection(P_w[s], ties.uv_cur[idx][s], cur.cal.K, cur.T_w_b_prior @ T_b_c0, cfg.pnp_reproj_px,
                      seed=cur.index)
        if r is not None and len(r[1]) > best:
            best, T_best = len(r[1]), r[0] @ inv_T(T_b_c0)
    return T_best if T_best is not None else cur.T_w_b_prior


def resection_inliers(cur: Site, T_w_b, P_w, ties: TieSet, idx, cfg) -> np.ndarray:
    """(n,) bool: tie points whose reprojection into their current left image under the resected
    pose is within ``pnp_reproj_px`` (the resection's RANSAC consensus, extended to all pairs)."""
    return _reprojection_px(cur, T_w_b, P_w, ties, idx) <= cfg.pnp_reproj_px


def prior_chi2(T_w_b_prior: np.ndarray, cov_prior: np.ndarray, T_w_b: np.ndarray) -> float:
    """Squared Mahalanobis distance of ``T_w_b`` (4x4) from the prior ``T_w_b_prior`` (4x4) under its
    covariance ``cov_prior`` (6x6, gtsam's body tangent: rotation then translation). Under the
    prior it is chi2-distributed with 6 degrees of freedom."""
    import gtsam
    xi = gtsam.Pose3.Logmap(gtsam.Pose3(np.asarray(T_w_b_prior, float)).between(gtsam.Pose3(np.asarray(T_w_b, float))))
    return float(xi @ np.linalg.solve(cov_prior, xi))


def tie_observations(ties: TieSet, idx) -> TieObservations:
    n = len(idx)
    return TieObservations(np.r_[np.zeros(n, int), np.ones(n, int)], np.r_[ties.pair_prev[idx], ties.pair_cur[idx]],
                           np.r_[np.arange(n), np.arange(n)], np.vstack([ties.uv_prev[idx], ties.uv_cur[idx]]),
                           np.r_[ties.ur_prev[idx], ties.ur_cur[idx]])


def _reprojection_px(cur: Site, T_w_b, P_w, ties: TieSet, idx) -> np.ndarray:
    """(n,) pixel distance of each tie's current-image observation from ``P_w`` projected with ``T_w_b``
    (inf behind the camera)."""
    from vo.crosssite.regions import project
    err = np.full(len(idx), np.inf)
    for j in np.unique(ties.pair_cur[idx]):
        s = ties.pair_cur[idx] == j
        uv, z = project(T_w_b @ cur.pairs[j].T_b_c0, cur.cal.K, P_w[s])
        err[s] = np.where(z > 0, np.linalg.norm(uv - ties.uv_cur[idx][s], axis=1), np.inf)
    return err


def second_motion(cur: Site, ties: TieSet, idx, P_w, keep, T_first, cfg) -> Optional[str]:
    """A second rigid motion among the ties the first resection consensus left out (``idx[~keep]``,
    their points ``P_w[~keep]`` as intersected at the previous site): resection again on them; if at least ``min_tie_points`` agree with it and their median reprojection
    under the first pose exceeds ``ambiguity_px``, the tie set holds two self-consistent motions (a
    wrong cluster can pass eq. 2 and out-vote the true ties) -> the reason string, else None. Ties that
    merely missed the first consensus by a few pixels (range errors of far points) reproject within a few
    pixels under the first pose and are the same motion."""
    rest = ~keep
    if cfg.ambiguity_px <= 0 or rest.sum() < cfg.min_tie_points:
        return None
    T2 = best_resection(cur, P_w[rest], ties, idx[rest], cfg)
    keep2 = resection_inliers(cur, T2, P_w[rest], ties, idx[rest], cfg)
    if keep2.sum() < cfg.min_tie_points:
        return None
    d = float(np.median(_reprojection_px(cur, T_first, P_w[rest][keep2], ties, idx[rest][keep2])))
    if d <= cfg.ambiguity_px:
        return None
    shift = float(np.linalg.norm(T2[:3, 3] - T_first[:3, 3]))
    return (f"two motions in the tie set: {int(keep.sum())} and {int(keep2.sum())} ties, {shift:.2f} m apart "
            f"(median {d:.0f} px > {cfg.ambiguity_px})")


def subsample_ties(idx: np.ndarray, n_max: int) -> np.ndarray:
    if len(idx) <= n_max:
        return idx
    return idx[np.linspace(0, len(idx) - 1, n_max).round().astype(int)]


def _ties(prev: Site, T_w_b_prev, cur: Site, cfg: CrossSiteConfig, cache) -> tuple:
    """Stages 1-5 with the matcher ``cfg.use_asift`` says. -> (TieSet, timings; ``cpu_asift`` the
    process CPU seconds of stages 1-3, which run on ``cfg.workers`` threads)."""
    c0 = time.process_time()
    ties = candidate_ties(prev, T_w_b_prev, cur, cfg, cache)
    cpu = time.process_time() - c0
    if len(ties.pair_prev):
        ties = stereo_and_consistency(prev, cur, ties, cfg, T_w_b_prev)
        if cfg.xsite_lsm:
            ties = refine_cross_site(prev, T_w_b_prev, cur, ties, cfg)
    ties.stats["matcher"] = "asift" if cfg.use_asift else "sift"
    return ties, dict(ties.timings_s, cpu_asift=cpu)


def localize_site(prev: Site, T_w_b_prev: np.ndarray, cur: Site, cfg: CrossSiteConfig = CrossSiteConfig()) -> SiteResult:
    """Localize ``cur`` against ``prev`` whose body pose ``T_w_b_prev`` is held fixed. With
    ``use_asift`` and ``asift_fallback_ties > 0``, plain SIFT first and ASIFT only when the SIFT ties
    do not give an ``ok`` pose or number fewer than ``asift_fallback_ties``. Timings: wall seconds
    per stage (the SIFT pass's prefixed ``sift_`` when ASIFT followed) and ``total``; ``cpu_asift``
    and ``cpu_total`` the process CPU seconds (all threads) of stages 1-3 and of the whole pair. The
    ASIFT pass reuses the SIFT pass's work (:class:`vo.crosssite.asift.DetectionCache`: the current
    images' features, ASIFT's tilt-1 view of each zoomed previous image and its nearest neighbours),
    which gives the same ties as computing them again."""
    c0, t0 = time.process_time(), time.perf_counter()
    cache = DetectionCache()
    if not (cfg.use_asift and cfg.asift_fallback_ties > 0):
        r = _localize_site(prev, T_w_b_prev, cur, cfg, cache)
    else:
        r = _localize_site(prev, T_w_b_prev, cur, dataclasses.replace(cfg, use_asift=False), cache)
        if r.status != "ok" or r.n_tie_points < cfg.asift_fallback_ties:
            first = {"sift_" + k: v for k, v in r.timings_s.items()}
            r2 = _localize_site(prev, T_w_b_prev, cur, cfg, cache)
            if r2.status == "ok" or r.status != "ok":
                r = r2
            r.timings_s.update(first)
    r.timings_s.update(total=time.perf_counter() - t0, cpu_total=time.process_time() - c0)
    return r


def _localize_site(prev: Site, T_w_b_prev: np.ndarray, cur: Site, cfg: CrossSiteConfig, cache=None) -> SiteResult:
    t0 = time.perf_counter()
    T_w_b_prev = np.asarray(T_w_b_prev, float)
    ties, timings = _ties(prev, T_w_b_prev, cur, cfg, cache)
    if len(ties.pair_prev) == 0:
        timings["total"] = time.perf_counter() - t0
        return _fallback(cur, "no_tie_points", cfg, ties, "no ASIFT matches in the predicted regions", timings)
    idx = subsample_ties(np.flatnonzero(ties.inlier), cfg.max_ba_points)
    if len(idx) < cfg.min_tie_points:
        timings["total"] = time.perf_counter() - t0
        status = "no_tie_points" if ties.stereo_ok.sum() == 0 else "few_tie_points"
        return _fallback(cur, status, cfg, ties, f"{len(idx)} tie points after the outlier test", timings)
    t1 = time.perf_counter()
    T_init, P_w = initial_pose(cur, T_w_b_prev, prev, ties, idx, cfg)
    keep = resection_inliers(cur, T_init, P_w, ties, idx, cfg)
    if keep.sum() < cfg.min_tie_points:
        timings.update(initial=time.perf_counter() - t1, total=time.perf_counter() - t0)
        return _fallback(cur, "few_tie_points", cfg, ties, f"{int(keep.sum())} tie points agree with the resection",
                         timings)
    if keep.sum() < cfg.min_ba_ties:
        timings.update(initial=time.perf_counter() - t1, total=time.perf_counter() - t0)
        return _fallback(cur, "few_tie_points", cfg, ties, f"{int(keep.sum())} tie points agree with the resection "
                         f"(min_ba_ties {cfg.min_ba_ties})", timings)
    ambiguous = second_motion(cur, ties, idx, P_w, keep, T_init, cfg)
    if ambiguous:
        timings.update(initial=time.perf_counter() - t1, total=time.perf_counter() - t0)
        return _fallback(cur, "ambiguous", cfg, ties, ambiguous, timings)
    idx, P_w = idx[keep], P_w[keep]
    t2 = time.perf_counter()
    try:
        res = bundle_adjust(T_w_b_prev, T_init, [[p.T_b_c0 for p in prev.pairs], [p.T_b_c0 for p in cur.pairs]],
                            tie_observations(ties, idx), P_w, cur.cal.K, cur.cal.baseline, cfg.ba_sigma_px,
                            cfg.ba_huber_k, cfg.mast_sigma_rad, cfg.mast_sigma_m,
                            xsite_sigma_px=cfg.ba_xsite_sigma_px)
    except RuntimeError as e:  # gtsam: indeterminant system, cheirality
        timings.update(initial=t2 - t1, bundle=time.perf_counter() - t2, total=time.perf_counter() - t0)
        return _fallback(cur, "few_tie_points", cfg, ties, f"bundle adjustment failed: {' '.join(str(e).split())[:160]}",
                         timings)
    timings.update(initial=t2 - t1, bundle=time.perf_counter() - t2, total=time.perf_counter() - t0)
    if not (np.all(np.isfinite(res.T_w_b)) and np.all(np.isfinite(res.cov))
            and np.linalg.eigvalsh(0.5 * (res.cov + res.cov.T)).min() > 0):
        return _fallback(cur, "few_tie_points", cfg, ties, "bundle adjustment gave a non-finite pose", timings)
    d2 = prior_chi2(cur.T_w_b_prior, cur.cov_prior, res.T_w_b)
    if d2 > cfg.prior_gate_chi2:
        return _fallback(cur, "few_tie_points", cfg, ties, f"BA pose disagrees with the prior (chi2 {d2:.1f} > "
                         f"{cfg.prior_gate_chi2})", timings)
    stats = dict(ties.stats, n_ba_points=len(idx), prior_chi2=round(d2, 2), ba_rms_px=round(res.rms_px, 4), ba_iterations=res.iterations)
    return SiteResult(cur.index, "ok", res.T_w_b, res.cov, int(ties.inlier.sum()), stats, timings, ties=ties)


def relative_prior_cov(prev: Site, cur: Site, floor: float = 1e-8) -> np.ndarray:
    """Covariance of the dead-reckoning motion from ``prev`` to ``cur`` in ``cur``'s body tangent: the
    cumulative covariances' difference ``C_cur - Ad C_prev Ad^T`` (``Ad`` the adjoint of the drive's
    inverse motion, which carries a perturbation of the previous pose to the current one), with
    eigenvalues clipped at ``floor``. Exact for independent increments; with a common slip bias it
    is larger than the leg's own covariance (conservative). The previous site is held fixed, so only
    this part of the dead reckoning's uncertainty widens the regions and gates the BA."""
    import gtsam
    D = gtsam.Pose3(inv_T(prev.T_w_b_prior) @ cur.T_w_b_prior)
    Ad = D.inverse().AdjointMap()
    C = cur.cov_prior - Ad @ prev.cov_prior @ Ad.T
    w, V = np.linalg.eigh(0.5 * (C + C.T))
    return (V * np.maximum(w, floor)) @ V.T


def leg_model_cov(prev: Site, cur: Site, cfg: CrossSiteConfig) -> np.ndarray:
    """6x6 diagonal floor of the leg's prior covariance: ``prior_rot_sigma_rad`` on each rotation and
    ``prior_leg_fraction`` of the leg length on each translation axis. Seed 001 states dead
    reckoning's expected error as up to 15 % of distance; the EKF's own leg covariance
    (:func:`relative_prior_cov`) can be far smaller than its actual leg error (correlated slip and
    attitude errors), and a too-small prior cuts the true overlap out of the regions and makes the
    chi2 gate refuse the true pose."""
    d = float(np.linalg.norm(cur.T_w_b_prior[:3, 3] - prev.T_w_b_prior[:3, 3]))
    return np.diag([cfg.prior_rot_sigma_rad ** 2] * 3 + [(cfg.prior_leg_fraction * d) ** 2] * 3)


def site_prior(prev: Site, T_w_b_prev: np.ndarray, cur: Site, cfg: CrossSiteConfig) -> Site:
    """``cur`` with the prior :func:`localize_traverse` gives it when ``prev`` is held at ``T_w_b_prev``
    (4,4): the dead-reckoning pose moved with the previous site's correction, the covariance of the
    leg (:func:`relative_prior_cov`) plus the leg-length floor (:func:`leg_model_cov`)."""
    shift = np.asarray(T_w_b_prev, float) @ inv_T(prev.T_w_b_prior)
    cov = relative_prior_cov(prev, cur) + leg_model_cov(prev, cur, cfg)
    return dataclasses.replace(cur, T_w_b_prior=shift @ cur.T_w_b_prior, cov_prior=cov)


def localize_traverse(sites: Sequence[Site], T_w_b0: np.ndarray, cfg: CrossSiteConfig = CrossSiteConfig(),
                      on_site=None) -> list:
    """Sites in driving order, site 0 at the known ``T_w_b0``: each site against the previous one's
    estimate (or kept prior). The dead-reckoning prior of site k is moved with the previous site's
    correction, ``T_prev_est @ inv(T_prev_prior) @ T_k_prior`` (the drive's relative motion is the
    dead reckoning's), with the covariance of that motion (:func:`relative_prior_cov`) plus the
    leg-length floor :func:`leg_model_cov`.
    ``on_site(result)`` is called after each site. -> [SiteResult] for sites 1..n-1."""
    out, T_prev = [], np.asarray(T_w_b0, float)
    for prev, cur in zip(sites[:-1], sites[1:]):
        r = localize_site(prev, T_prev, site_prior(prev, T_prev, cur, cfg), cfg)
        if on_site is not None:
            on_site(r)
        out.append(r)
        T_prev = r.T_w_b
    return out
