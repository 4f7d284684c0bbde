"""The seed 001 accuracy model (eq. 9-13, :mod:`vo.errorprop.crosssite`) against the localizer, per
site pair of a localized traverse.

For each site pair with status ``ok``: the tie points the BA kept (eq. 2 inliers that agree with the
BA pose, :func:`ba_ties`), intersected at the previous site, give the landmark layout in the previous site's body frame (x forward, y left); the
current site's true position in that frame is ``current_site``. The model's ``sigma_pos_m``
(``sqrt(trace(M_p))``, horizontal) is set against the BA's actual horizontal error of the pair
step (the current site's error relative to the previous site's estimate, in the previous site's
frame) and the BA's own Marginals (horizontal part of the body-frame position covariance). With one
or a few traverses this is per pair, not a Monte Carlo spread: a single error sample per pair.
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import inv_T
from vo.crosssite.regions import project
from vo.crosssite.ties import body_points
from vo.errorprop.crosssite import (CrossSiteConfig as ModelConfig, cross_site_accuracy, design_matrix,
                                    tie_point_covariance)


def pair_layout(prev, res, idx=None) -> np.ndarray:
    """(N,2) tie points (eq. 2 inliers, or the ties ``idx``) in the previous site's body frame, xy."""
    t = res.ties
    idx = np.flatnonzero(t.inlier) if idx is None else np.asarray(idx, int)
    P_b, _ = body_points(prev, t.pair_prev[idx], t.uv_prev[idx], t.ur_prev[idx], prev.cal.K, prev.cal.baseline)
    return P_b[:, :2]


def model_vs_ba(run, sites, sigma_p_px: float = 1.0 / 3.0, sigma_theta_px: float = 3.0, reproj_px: float = 2.0) -> list:
    """One dict per ``ok`` site pair: n tie points, model sigma (m), BA marginal sigma (m), BA actual
    horizontal error of the step (m), step length (m). ``sites`` the read traverse's Site records. The
    layout is the ties that agree with the BA pose (:func:`ba_ties`, ``reproj_px`` the localizer's
    ``pnp_reproj_px``), not every eq. 2 inlier (see :func:`ba_ties`)."""
    rows = []
    for r in run.results:
        if r.status != "ok" or r.ties is None:
            continue
        k = r.index
        prev = sites[k - 1]
        lm = pair_layout(prev, r, ba_ties(prev, sites[k], r, run.T_w_b_est[k - 1], reproj_px))
        if len(lm) < 2:
            continue
        T_rel_true = inv_T(run.T_w_b_true[k - 1]) @ run.T_w_b_true[k]
        T_rel_est = inv_T(run.T_w_b_est[k - 1]) @ run.T_w_b_est[k]
        cur_xy = T_rel_true[:2, 3]
        model = cross_site_accuracy(ModelConfig(f_px=prev.cal.f, baseline_m=prev.cal.baseline, sigma_p_px=sigma_p_px,
                                                sigma_theta_px=sigma_theta_px, previous_site=(0.0, 0.0),
                                                current_site=tuple(cur_xy), landmarks=tuple(map(tuple, lm))))
        # BA covariance: body frame of the current site -> previous site's frame, horizontal part
        R = T_rel_est[:3, :3]
        C = R @ r.cov[3:, 3:] @ R.T
        rows.append({"site": k, "tie_points": len(lm), "step_m": round(float(np.linalg.norm(cur_xy)), 3),
                     "model_sigma_m": round(model.sigma_pos_m, 4), "ba_sigma_m": round(float(np.sqrt(np.trace(C[:2, :2]))), 4),
                     "ba_step_err_m": round(float(np.linalg.norm(T_rel_est[:2, 3] - cur_xy)), 4),
                     "model_pct": round(model.accuracy_percent, 3)})
    return rows


def format_model_rows(rows: list) -> str:
    lines = [f"{'pair':>7} {'ties':>5} {'step m':>7} {'model sig m':>11} {'BA sig m':>9} {'BA err m':>9}"]
    for r in rows:
        lines.append(f"{r['site'] - 1:>3}->{r['site']:<3} {r['tie_points']:>5} {r['step_m']:>7.2f} {r['model_sigma_m']:>11.4f} "
                     f"{r['ba_sigma_m']:>9.4f} {r['ba_step_err_m']:>9.4f}")
    return "\n".join(lines)


# --- Monte Carlo check (docs/studies/crosssite_model_mc.py): per-axis model, measured sigmas -----------

def model_covariance(layout_xy: np.ndarray, cur_xy, f_px: float, baseline_m: float, sigma_p_px: float,
                     sigma_theta_px: float, sigma_p_cur_px: float = 0.0, scale: bool = True) -> np.ndarray:
    """Eq. 9-13 ``M_p`` (2,2) of the current site in the previous site's body frame (x forward, y left)
    for tie points ``layout_xy`` (N,2) in that frame and the current site at ``cur_xy``.

    ``sigma_p_cur_px = 0``: the paper's model, only the previous site's stereo errors (eq. 7-8) weigh
    the similarity fit (the current site's tie coordinates are error-free coefficients of ``A``).
    ``> 0``: the current site's stereo range errors too (eq. 7 from the current site, azimuth error
    left on the previous site's side, where the cross-site matching error ``sigma_theta`` is put):
    the fit's residual covariance is the sum of both sites' tie-point covariances (first order).
    ``scale = False``: a rigid transform (rotation angle, translation; the similarity linearized at
    ``a = 1, b = 0`` without the scale), as in the BA, where the fixed stereo baseline sets the scale."""
    from scipy.linalg import block_diag
    lm = np.asarray(layout_xy, float)
    cfg = ModelConfig(f_px=f_px, baseline_m=baseline_m, sigma_p_px=sigma_p_px, sigma_theta_px=sigma_theta_px,
                      previous_site=(0.0, 0.0), current_site=tuple(map(float, cur_xy)), landmarks=tuple(map(tuple, lm)))
    M = block_diag(*[tie_point_covariance(cfg.previous_site, q, cfg) for q in lm])
    if sigma_p_cur_px > 0:
        cfg_c = ModelConfig(f_px=f_px, baseline_m=baseline_m, sigma_p_px=sigma_p_cur_px, sigma_theta_px=1e-6,
                            current_site=cfg.current_site, landmarks=cfg.landmarks)
        M = M + block_diag(*[tie_point_covariance(cfg.current_site, q, cfg_c) for q in lm])
    A = design_matrix(lm)
    xp, yp = cfg.current_site
    C = np.array([[xp, -yp, 1, 0], [yp, xp, 0, 1]])
    if not scale:                      # columns (b, c, d): dX = -y db + dc, dY = x db + dd
        A, C = A[:, 1:], C[:, 1:]
    M_T = np.linalg.inv(A.T @ np.linalg.solve(M, A))
    return C @ M_T @ C.T


def ba_ties(prev, cur, res, T_w_b_prev, reproj_px: float) -> np.ndarray:
    """Indices (into ``res.ties``) of the eq. 2 inliers that agree with the BA pose: intersected at the
    previous site and reprojected into their current left image within ``reproj_px`` (the localizer's
    resection consensus, ``pnp_reproj_px``, evaluated at the final pose). The eq. 2 inliers alone still
    hold wrong ties in some runs (cross-site transfer errors of 10-150 px robust sigma) that the
    resection and the BA's residual test drop: a model fed with them mis-states the layout and sigmas."""
    t = res.ties
    idx = np.flatnonzero(t.inlier)
    P_b, _ = body_points(prev, t.pair_prev[idx], t.uv_prev[idx], t.ur_prev[idx], prev.cal.K, prev.cal.baseline)
    P_w = P_b @ T_w_b_prev[:3, :3].T + T_w_b_prev[:3, 3]
    keep = np.zeros(len(idx), bool)
    for j in np.unique(t.pair_cur[idx]):
        s = t.pair_cur[idx] == j
        uv, z = project(res.T_w_b @ cur.pairs[j].T_b_c0, cur.cal.K, P_w[s])
        keep[s] = (z > 0) & (np.linalg.norm(uv - t.uv_cur[idx][s], axis=1) <= reproj_px)
    return idx[keep]


def track_axes(cur_xy) -> np.ndarray:
    """(2,2) rows: the along-track unit vector (previous -> current site) and the cross-track one (left)."""
    a = np.asarray(cur_xy, float) / np.linalg.norm(cur_xy)
    return np.array([a, [-a[1], a[0]]])


def axis_sigmas(M_p: np.ndarray, cur_xy) -> tuple:
    """(along-track, cross-track) 1-sigma (m) of a planar covariance ``M_p``."""
    A = track_axes(cur_xy)
    C = A @ M_p @ A.T
    return float(np.sqrt(C[0, 0])), float(np.sqrt(C[1, 1]))


def tie_errors_vs_depth(prev, cur, res, T_w_b_prev, T_w_b_cur, depths_prev, idx=None) -> tuple:
    """Errors of the kept tie points (eq. 2 inliers, or the ties ``idx``) against exact correspondences, from the previous
    site's rendered depth (``depths_prev`` one (H,W) map per pair, metres along the optical axis) and
    the true poses. -> (disparity error at the previous site (n,) px: ``u_l - u_r - f B / z``,
    disparity error at the current site (n,) px (truth: the point's depth in the current left camera),
    cross-site transfer error (n,2) px: the current pixel minus the previous pixel moved with depth and
    poses, the same error in previous-image pixels (n,2): times ``z_cur / z_prev``, the lateral error
    of the tie seen from the previous site, i.e. its azimuth error there in pixels). NaN where the
    depth is not finite."""
    t, K, f, B = res.ties, prev.cal.K, prev.cal.f, prev.cal.baseline
    idx = np.flatnonzero(t.inlier) if idx is None else np.asarray(idx, int)
    n = len(idx)
    d_prev, d_cur, transfer, at_prev = np.full(n, np.nan), np.full(n, np.nan), np.full((n, 2), np.nan), np.full((n, 2), np.nan)
    H, W = depths_prev[0].shape
    for m, k in enumerate(idx):
        i, j = t.pair_prev[k], t.pair_cur[k]
        u, v = t.uv_prev[k]
        z = float(depths_prev[i][min(max(int(round(v)), 0), H - 1), min(max(int(round(u)), 0), W - 1)])
        if not np.isfinite(z):
            continue
        d_prev[m] = (u - t.ur_prev[k]) - f * B / z
        T_w_c = T_w_b_prev @ prev.pairs[i].T_b_c0
        P_w = T_w_c[:3, :3] @ (np.linalg.solve(K, [u, v, 1.0]) * z) + T_w_c[:3, 3]
        uv, zc = project(T_w_b_cur @ cur.pairs[j].T_b_c0, K, P_w[None])
        if zc[0] > 0:
            transfer[m] = t.uv_cur[k] - uv[0]
            at_prev[m] = transfer[m] * zc[0] / z
            d_cur[m] = (t.uv_cur[k][0] - t.ur_cur[k]) - f * B / zc[0]
    return d_prev, d_cur, transfer, at_prev


def robust_sigma(x) -> float:
    """1.4826 x the median absolute deviation of the finite values of ``x`` (NaN if none)."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(1.4826 * np.median(np.abs(x - np.median(x)))) if x.size else float("nan")
