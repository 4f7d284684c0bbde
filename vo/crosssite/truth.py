"""Tie points scored against the truth of a simulated traverse.

A tie is true when its current-site stereo point (left pixel + matched right column, intersected in
the rectified current pair), moved with the true poses into the previous site's left camera, lands
within ``tol_px`` of the tie's previous pixel. The current site sees the overlap at 2-20 m, where its
stereo range error moves the point mostly along the previous camera's ray, so the check resolves a
few pixels (``tol_px`` 4 by default). Used for the per-stage figures; never by the localizer.
"""
from __future__ import annotations

import numpy as np

from vo.crosssite import regions
from vo.crosssite.intersect_resect import intersect_rectified


def true_ties(prev, cur, ties, T_w_b_prev_true: np.ndarray, T_w_b_cur_true: np.ndarray,
              tol_px: float = 4.0, depth_prev: np.ndarray = None) -> np.ndarray:
    """(n,) bool over the tie set: stereo-matched at the current site and true (see module doc).
    ``depth_prev`` (n,), if given, receives each point's depth in the previous left camera."""
    n = len(ties.pair_prev)
    out = np.zeros(n, bool)
    if n == 0 or ties.ur_cur is None:
        return out
    ok = np.isfinite(ties.ur_cur)
    K, B = cur.cal.K, cur.cal.baseline
    for j in np.unique(ties.pair_cur[ok]):
        s = np.flatnonzero(ok & (ties.pair_cur == j))
        P_c = intersect_rectified(ties.uv_cur[s], ties.ur_cur[s], K, B)
        P_w = (T_w_b_cur_true @ cur.pairs[j].T_b_c0 @ np.c_[P_c, np.ones(len(s))].T)[:3].T
        for i in np.unique(ties.pair_prev[s]):
            t = ties.pair_prev[s] == i
            uv, z = regions.project(T_w_b_prev_true @ prev.pairs[i].T_b_c0, K, P_w[t])
            out[s[t]] = (z > 0) & (np.linalg.norm(uv - ties.uv_prev[s[t]], axis=1) <= tol_px)
            if depth_prev is not None:
                depth_prev[s[t]] = z
    return out


def tie_truth_stats(prev, cur, ties, T_w_b_prev_true, T_w_b_cur_true, tol_px: float = 4.0) -> dict:
    """Counts of true ties among the candidates, the stereo-accepted ones and the eq. 2 inliers; the
    median depth of the true inliers in the previous camera and how many lie beyond 20 m."""
    if ties is None or ties.ur_cur is None:
        return {}
    z = np.full(len(ties.pair_prev), np.nan)
    t = true_ties(prev, cur, ties, T_w_b_prev_true, T_w_b_cur_true, tol_px, z)
    st = ties.stereo_ok if ties.stereo_ok is not None else np.zeros(len(t), bool)
    inl = ties.inlier if ties.inlier is not None else np.zeros(len(t), bool)
    zt = z[t & inl]
    return {"n_true_candidates": int(t.sum()), "n_true_stereo_ok": int((t & st).sum()),
            "n_stereo_ok": int(st.sum()), "n_true_inliers": int((t & inl).sum()), "n_inliers": int(inl.sum()),
            "true_inlier_depth_prev_median_m": round(float(np.median(zt)), 2) if len(zt) else None,
            "true_inliers_beyond_20m": int((zt > 20.0).sum())}
