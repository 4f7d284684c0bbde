"""Tie points between two sites: stages 1-5 of seed 001 §2 (regions, Wallis, ASIFT, stereo ZNCC +
LSM, distance consistency) on :class:`vo.crosssite.types.Site` records, and the optional least-squares
refinement of the cross-site ties (:func:`refine_cross_site`, beyond the paper)."""
from __future__ import annotations

import dataclasses
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import cv2
import numpy as np

from vo.crosssite import asift, ortho, regions, wallis, zoom
from vo.crosssite.distance_test import distance_consistency, range_sigma
from vo.crosssite.intersect_resect import intersect_rectified
from vo.crosssite.zncc import lsm_refine, match_stereo


@dataclass
class TieSet:
    """Candidate ties between previous pair ``pair_prev[k]`` pixel ``uv_prev[k]`` and current pair
    ``pair_cur[k]`` pixel ``uv_cur[k]``; after stereo: right columns ``ur_prev``, ``ur_cur`` and
    ``stereo_ok``; after eq. 2: ``inlier``. ``boxes[(i, j)]`` the predicted regions."""

    pair_prev: np.ndarray
    uv_prev: np.ndarray
    pair_cur: np.ndarray
    uv_cur: np.ndarray
    ur_prev: np.ndarray = None
    ur_cur: np.ndarray = None
    stereo_ok: np.ndarray = None
    inlier: np.ndarray = None
    boxes: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)
    timings_s: dict = field(default_factory=dict)


def pair_regions(prev, T_w_b_prev, cur, cfg) -> dict:
    """{(i, j): (box prev, box cur)} for every pair combination whose predicted regions exist."""
    K, W, H = cur.cal.K, cur.cal.width, cur.cal.height
    fn = regions.forward_forward if cfg.mode == "ff" else regions.forward_backward
    out = {}
    for i, pp in enumerate(prev.pairs):
        for j, pc in enumerate(cur.pairs):
            if not cfg.use_regions:
                out[(i, j)] = ((0, 0, W, H), (0, 0, W, H))
                continue
            bp, bc = fn(T_w_b_prev @ pp.T_b_c0, cur.T_w_b_prior @ pc.T_b_c0, cur.T_w_b_prior, cur.cov_prior,
                        K, W, H, cfg.region_max_range_m, cfg.region_sigma)
            if bp is not None and bc is not None:
                out[(i, j)] = (bp, bc)
    return out


def predicted_tilt(prev, T_w_b_prev, cur, boxes, cfg) -> tuple:
    """Median predicted transition tilt (and its scale) over the region pairs, at the ground point
    seen at each current box centre."""
    K = cur.cal.K
    found = []
    for (i, j), (_, bc) in boxes.items():
        T_w_c = cur.T_w_b_prior @ cur.pairs[j].T_b_c0
        ray = np.linalg.solve(K, [(bc[0] + bc[2]) / 2, (bc[1] + bc[3]) / 2, 1.0])
        d_w, o_w = T_w_c[:3, :3] @ ray, T_w_c[:3, 3]
        z0 = cur.T_w_b_prior[2, 3]
        if d_w[2] >= -1e-6:
            continue
        p = o_w + d_w * (z0 - o_w[2]) / d_w[2]
        tau, s = asift.transition(T_w_b_prev @ prev.pairs[i].T_b_c0, T_w_c, K, p)
        found.append((tau, s))
    return tuple(float(v) for v in np.median(np.array(found), axis=0)) if found else (1.0, 1.0)


def _enhanced(prev, cur, boxes, cfg) -> tuple:
    """Left images after the Wallis filter (eq. 1), both towards the current regions' statistics."""
    W, H = cur.cal.width, cur.cal.height
    if not cfg.use_wallis:
        return [p.left for p in prev.pairs], [p.left for p in cur.pairs]
    sel = [cur.pairs[j].left[regions.box_mask(bc, W, H) > 0] for (_, j), (_, bc) in boxes.items()]
    vals = np.concatenate(sel) if sel else np.concatenate([p.left.ravel() for p in cur.pairs])
    m_f, s_f = float(vals.mean()), max(float(vals.std()), 1.0)
    f = lambda im: wallis.wallis(im, m_f, s_f, cfg.wallis_b, cfg.wallis_c, cfg.wallis_window_px)  # noqa: E731
    return [f(p.left) for p in prev.pairs], [f(p.left) for p in cur.pairs]


def _detect(im, m, tilts, cfg, cache=None):
    if m is None or not np.any(m):
        return np.zeros((0, 2)), np.zeros((0, 128), np.float32)
    return asift.detect(im, m, tilts, cfg.sift_features, cfg.use_asift, cfg.sift_contrast, cache)


def _detect_all(images, masks, tilts, cfg, cache=None):
    return _map(lambda im_m: _detect(*im_m, tilts, cfg, cache), list(zip(images, masks)), cfg.workers)


def _map(fn, items: list, workers: int) -> list:
    """``[fn(x) for x in items]`` on ``workers`` threads (OpenCV's detection and matching release the
    GIL); results in the order of ``items`` whatever the threads' timing."""
    if workers <= 1 or len(items) <= 1:
        return [fn(x) for x in items]
    with ThreadPoolExecutor(max_workers=workers) as ex:
        return list(ex.map(fn, items))


def _nominal_overlap(prev, T_w_b_prev, cur, i, j, cfg) -> bool:
    """Whether the two views overlap at the prior pose itself (regions without margins): the pairs
    that only the prior's 3-sigma margins join are not worth a zoomed matching."""
    K, W, H = cur.cal.K, cur.cal.width, cur.cal.height
    bp, bc = regions.forward_forward(T_w_b_prev @ prev.pairs[i].T_b_c0, cur.T_w_b_prior @ cur.pairs[j].T_b_c0,
                                     cur.T_w_b_prior, cur.cov_prior, K, W, H, cfg.region_max_range_m, 0.0)
    return bp is not None and bc is not None


def _zoomed_rows(prev, T_w_b_prev, cur, boxes, imgs_p, feats_c, tilts, cfg, cache=None) -> tuple:
    """Matches per region pair with the previous image zoomed into the current geometry
    (:mod:`vo.crosssite.zoom`); previous pixels mapped back. -> (rows, n previous features, n warped pairs)."""
    W, H = cur.cal.width, cur.cal.height

    def one(item):
        (i, j), (bp, bc) = item
        if cfg.mode == "ff" and not _nominal_overlap(prev, T_w_b_prev, cur, i, j, cfg):
            return None
        M = zoom.pair_warp(prev, T_w_b_prev, cur, i, j, bp, bc, cfg)
        if M is None:
            return None
        warped, valid = zoom.warp_image(imgs_p[i], M, W, H)
        uv_w, d_a = _detect(warped, valid & regions.box_mask(bc, W, H), tilts, cfg, cache)
        uv_b, d_b = feats_c[j]
        ib = np.flatnonzero(regions.in_box(uv_b, bc))
        ab = asift.match(d_a, d_b[ib], cfg.ratio, cache)
        uv_a = zoom.unwarp_points(uv_w[ab[:, 0]], M) if len(ab) else ()
        return [(i, *a, j, *uv_b[b]) for a, b in zip(uv_a, ib[ab[:, 1]])], len(uv_w)

    done = [r for r in _map(one, list(boxes.items()), cfg.workers) if r is not None]
    return [row for rows, _ in done for row in rows], sum(n for _, n in done), len(done)


def candidate_ties(prev, T_w_b_prev, cur, cfg, cache=None) -> TieSet:
    """Stages 1-3: regions, Wallis, ASIFT (or SIFT) matching inside the regions; features from
    ``cache`` (:class:`vo.crosssite.asift.DetectionCache`) where an earlier pass detected them."""
    t0 = time.perf_counter()
    W, H = cur.cal.width, cur.cal.height
    boxes = pair_regions(prev, T_w_b_prev, cur, cfg)
    tau, scale = predicted_tilt(prev, T_w_b_prev, cur, boxes, cfg)
    tilts = asift.tilt_set(1.0 if cfg.zoom in ("plane", "ortho") else tau, cfg.asift_max_tilt)
    t1 = time.perf_counter()
    imgs_p, imgs_c = _enhanced(prev, cur, boxes, cfg)
    t2 = time.perf_counter()
    mask_p = [_union([bp for (i, _), (bp, _) in boxes.items() if i == k], W, H) for k in range(len(prev.pairs))]
    mask_c = [_union([bc for (_, j), (_, bc) in boxes.items() if j == k], W, H) for k in range(len(cur.pairs))]
    # with a zoom the previous image is already in the current geometry: the affine views (if any)
    # are simulated on the zoomed previous image only, the current image keeps plain SIFT
    cfg_c = dataclasses.replace(cfg, use_asift=False) if cfg.zoom != "none" else cfg
    feats_c = _detect_all(imgs_c, mask_c, tilts, cfg_c, cache) if cfg.zoom != "ortho" else []
    n_feat_c = sum(len(f[0]) for f in feats_c)
    if cfg.zoom == "ortho":  # both images onto one ground grid per region pair (vo.crosssite.ortho)
        rows, n_feat_p, n_feat_c, n_warped = ortho.ortho_rows(prev, T_w_b_prev, cur, boxes, imgs_p, imgs_c, tilts, cfg)
    elif cfg.zoom != "none":
        rows, n_feat_p, n_warped = _zoomed_rows(prev, T_w_b_prev, cur, boxes, imgs_p, feats_c, tilts, cfg, cache)
    else:
        feats_p, rows, n_warped = _detect_all(imgs_p, mask_p, tilts, cfg, cache), [], 0
        n_feat_p = sum(len(f[0]) for f in feats_p)
        for (i, j), (bp, bc) in boxes.items():
            (uv_a, d_a), (uv_b, d_b) = feats_p[i], feats_c[j]
            ia, ib = np.flatnonzero(regions.in_box(uv_a, bp)), np.flatnonzero(regions.in_box(uv_b, bc))
            for a, b in asift.match(d_a[ia], d_b[ib], cfg.ratio, cache):
                rows.append((i, *uv_a[ia[a]], j, *uv_b[ib[b]]))
    r = _unique(np.array(rows, float).reshape(-1, 6))
    ties = TieSet(r[:, 0].astype(int), r[:, 1:3], r[:, 3].astype(int), r[:, 4:6], boxes=boxes)
    ties.stats.update(tilts=[round(t, 3) for t in tilts], predicted_tilt=round(tau, 3), predicted_scale=round(scale, 3),
                      n_region_pairs=len(boxes), n_zoomed_pairs=n_warped, n_features_prev=n_feat_p,
                      n_features_cur=n_feat_c, n_candidates=len(r))
    ties.timings_s.update(regions=t1 - t0, wallis=t2 - t1, asift=time.perf_counter() - t2)
    return ties


def _union(boxes, W, H):
    if not boxes:
        return None
    m = np.zeros((H, W), np.uint8)
    for b in boxes:
        m |= regions.box_mask(b, W, H)
    return m


def _unique(r: np.ndarray) -> np.ndarray:
    """One tie per previous keypoint and per current keypoint (ASIFT repeats a point over views)."""
    if len(r) == 0:
        return r
    _, first_p = np.unique(np.round(r[:, :3], 1), axis=0, return_index=True)
    r = r[np.sort(first_p)]
    _, first_c = np.unique(np.round(r[:, 3:], 1), axis=0, return_index=True)
    return r[np.sort(first_c)]


def prior_gate(prev, T_w_b_prev, cur, ties: TieSet, idx, P_b_prev, cfg) -> np.ndarray:
    """(len(idx),) bool: the tie's current pixel lies within the predicted region of its own point,
    the §2.1 region applied point by point: the previous-site intersection moved into the current
    image with the prior pose, within ``region_sigma`` times the prior covariance propagated through
    that point's projection (``regions.point_margins_px``), plus 3 px."""
    ok = np.zeros(len(idx), bool)
    P_w = P_b_prev @ T_w_b_prev[:3, :3].T + T_w_b_prev[:3, 3]
    for j in np.unique(ties.pair_cur[idx]):
        s = ties.pair_cur[idx] == j
        T_b_c = cur.pairs[j].T_b_c0
        uv, z = regions.project(cur.T_w_b_prior @ T_b_c, cur.cal.K, P_w[s])
        margin = regions.point_margins_px(lambda T: regions.project(T @ T_b_c, cur.cal.K, P_w[s])[0],  # noqa: B023
                                          cur.T_w_b_prior, cur.cov_prior, cfg.region_sigma)
        ok[s] = (z > 0) & (np.linalg.norm(uv - ties.uv_cur[idx][s], axis=1) <= margin + 3.0)
    return ok


def stereo_and_consistency(prev, cur, ties: TieSet, cfg, T_w_b_prev=None) -> TieSet:
    """Stages 4-5: ZNCC + median + LSM stereo matching at both sites, then eq. 2 on the survivors."""
    t0 = time.perf_counter()
    f, B, K = cur.cal.f, cur.cal.baseline, cur.cal.K
    n = len(ties.pair_prev)
    ur = {}
    ok = np.ones(n, bool)
    for name, site, pair_idx, uv in (("prev", prev, ties.pair_prev, ties.uv_prev), ("cur", cur, ties.pair_cur, ties.uv_cur)):
        u_r = np.full(n, np.nan)
        for k in np.unique(pair_idx):
            sel = np.flatnonzero(pair_idx == k)
            m = match_stereo(site.pairs[k].left, site.pairs[k].right, uv[sel], f, B, cfg)
            u_r[sel] = m.uv_r[:, 0]
        ur[name] = u_r
        ok &= np.isfinite(u_r)
    ties.ur_prev, ties.ur_cur, ties.stereo_ok = ur["prev"], ur["cur"], ok
    t1 = time.perf_counter()
    idx = np.flatnonzero(ok)
    P1, P2 = body_points(prev, ties.pair_prev[idx], ties.uv_prev[idx], ur["prev"][idx], K, B), \
        body_points(cur, ties.pair_cur[idx], ties.uv_cur[idx], ur["cur"][idx], K, B)
    if T_w_b_prev is not None and cfg.use_regions:
        g = prior_gate(prev, T_w_b_prev, cur, ties, idx, P1[0], cfg)
        idx, P1, P2 = idx[g], (P1[0][g], P1[1][g]), (P2[0][g], P2[1][g])
    ties.stats.update(n_prior_gate=int(len(idx)))
    s1 = range_sigma(P1[1], f, B, cfg.sigma_p_px)
    s2 = range_sigma(P2[1], f, B, cfg.sigma_p_px)
    inl, _ = distance_consistency(P1[0], P2[0], s1, s2, cfg.consistency_abs_m, cfg.consistency_k_sigma,
                                  cfg.weight_fraction, cfg.consistency_iterations)
    ties.inlier = np.zeros(n, bool)
    ties.inlier[idx[inl]] = True
    ties.stats.update(n_stereo_ok=int(ok.sum()), n_consistent=int(ties.inlier.sum()))
    ties.timings_s.update(stereo=t1 - t0, consistency=time.perf_counter() - t1)
    return ties


def body_points(site, pair_idx, uv_l, u_r, K, B) -> tuple:
    """(points in the site's body frame (N,3), in the camera frames (N,3)) by space intersection."""
    P_c = intersect_rectified(uv_l, u_r, K, B)
    P_b = np.empty_like(P_c)
    for k in np.unique(pair_idx):
        s = pair_idx == k
        T = site.pairs[k].T_b_c0
        P_b[s] = P_c[s] @ T[:3, :3].T + T[:3, 3]
    return P_b, P_c


def homography_jacobian(M: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """2x2 derivative of the 3x3 map ``M`` (pixel -> pixel) at ``uv``: the local affine it implies."""
    x = M @ np.array([uv[0], uv[1], 1.0])
    p = x[:2] / x[2]
    return (M[:2, :2] - np.outer(p, M[2, :2])) / x[2]


def refine_cross_site(prev, T_w_b_prev, cur, ties: TieSet, cfg) -> TieSet:
    """Least-squares matching of the eq. 2 ties across sites (``cfg.xsite_lsm``; seed 001 applies LSM to
    the stereo matches only, this is an extension). Each tie's current left pixel is refined by
    :func:`vo.crosssite.zncc.lsm_refine` of the previous left image (as the matcher saw it: Wallis-filtered
    when ``use_wallis``) against the current one (low-passed to the previous resolution), the previous
    window resampled through the ground-plane homography of the prior pose
    (:func:`vo.crosssite.zoom.plane_homography`; the identity where it does not exist). The current
    right column follows by a stereo LSM started from the old disparity. A tie whose refinement fails or
    moves more than ``xsite_lsm_max_shift_px`` leaves the inliers. Refining after eq. 2 touches only the
    ties eq. 2 kept (tens to hundreds, against thousands of candidates). -> ``ties``, updated in place."""
    t0 = time.perf_counter()
    idx = np.flatnonzero(ties.inlier) if ties.inlier is not None else np.zeros(0, int)
    if len(idx) == 0:
        return ties
    K, W, H = cur.cal.K, cur.cal.width, cur.cal.height
    imgs_p, imgs_c = _enhanced(prev, cur, ties.boxes, cfg)
    h, m_st = cfg.xsite_lsm_half_px, cfg.lsm_half_px + 2
    n_drop = 0
    for i, j in {(int(a), int(b)) for a, b in zip(ties.pair_prev[idx], ties.pair_cur[idx])}:
        M = zoom.plane_homography(T_w_b_prev @ prev.pairs[i].T_b_c0, cur.T_w_b_prior @ cur.pairs[j].T_b_c0,
                                  cur.T_w_b_prior, K, W, H, cfg.region_max_range_m)
        sel = idx[(ties.pair_prev[idx] == i) & (ties.pair_cur[idx] == j)]
        img_c = _to_previous_resolution(imgs_c[j], M, ties.uv_prev[sel])
        for n in sel:
            r = _refine_one(imgs_p[i], img_c, cur.pairs[j], ties, n, M, h, m_st, cfg)
            if r is None:
                ties.inlier[n] = False
                n_drop += 1
            else:
                ties.uv_cur[n], ties.ur_cur[n] = r[:2], r[2]
    ties.stats.update(n_xsite_lsm_dropped=n_drop, n_consistent=int(ties.inlier.sum()))
    ties.timings_s.update(xsite_lsm=time.perf_counter() - t0)
    return ties


def _to_previous_resolution(img: np.ndarray, M, uv_prev: np.ndarray) -> np.ndarray:
    """The current image low-passed to the previous image's resolution: a previous pixel covers ``s``
    current pixels (``s`` the median of ``sqrt|det J|`` of the homography ``M`` at the ties), so a
    Gaussian of ``0.5 sqrt(s^2 - 1)`` px (the previous pixel's footprint less the current one's);
    without it the sharper current window pulls the match by a few tenths of a pixel."""
    if M is None or len(uv_prev) == 0:
        return img
    s = float(np.median([np.sqrt(abs(np.linalg.det(homography_jacobian(M, uv)))) for uv in uv_prev]))
    if not np.isfinite(s) or s <= 1.0:
        return img
    return cv2.GaussianBlur(img.astype(np.float32), (0, 0), 0.5 * np.sqrt(s * s - 1.0))


def _inside(uv, margin: float, W: int, H: int) -> bool:
    return bool(margin <= uv[0] < W - margin and margin <= uv[1] < H - margin)


def _refine_one(img_p, img_c, pair_c, ties: TieSet, n: int, M, half: int, m_stereo: int, cfg):
    """(u, v, u_r) of tie ``n`` after the cross-site and the current stereo LSM, or None."""
    H, W = img_c.shape[:2]
    A0 = homography_jacobian(M, ties.uv_prev[n]) if M is not None else np.eye(2)
    if not np.all(np.isfinite(A0)) or abs(np.linalg.det(A0)) < 1e-6:
        M, A0 = None, np.eye(2)
    reach_p = 1.5 * half * float(np.abs(np.linalg.inv(A0)).sum(axis=1).max()) + 2
    reach_c = half + cfg.xsite_lsm_max_shift_px + 2
    if not (_inside(ties.uv_prev[n], reach_p, W, H) and _inside(ties.uv_cur[n], reach_c, W, H)):
        return None
    r = lsm_refine(img_p, img_c, ties.uv_prev[n], ties.uv_cur[n], half, cfg.xsite_lsm_max_shift_px, M)
    if r is None:
        return None
    uv = np.array(r)
    ur0 = np.array([ties.ur_cur[n] + uv[0] - ties.uv_cur[n, 0], uv[1]])
    if not (_inside(uv, m_stereo, W, H) and _inside(ur0, m_stereo + cfg.lsm_max_shift_px, W, H)):
        return None
    s = lsm_refine(pair_c.left, pair_c.right, uv, ur0, cfg.lsm_half_px, cfg.lsm_max_shift_px)
    return None if s is None else (uv[0], uv[1], s[0])
