"""The seed 001 accuracy model (eq. 9-13, :mod:`vo.errorprop.crosssite`) against the localizer, per
site pair of a localized traverse.

For each site pair with status ``ok``: the tie points kept by the outlier test, intersected at the
previous site, give the landmark layout in the previous site's body frame (x forward, y left); the
current site's true position in that frame is ``current_site``. The model's ``sigma_pos_m``
(``sqrt(trace(M_p))``, horizontal) is set against the BA's actual horizontal error of the pair
step (the current site's error relative to the previous site's estimate, in the previous site's
frame) and the BA's own Marginals (horizontal part of the body-frame position covariance). With one
or a few traverses this is per pair, not a Monte Carlo spread: a single error sample per pair.
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import inv_T


def pair_layout(prev, res) -> np.ndarray:
    """(N,2) tie points (eq. 2 inliers) in the previous site's body frame, xy."""
    from vo.crosssite.ties import body_points
    t = res.ties
    idx = np.flatnonzero(t.inlier)
    P_b, _ = body_points(prev, t.pair_prev[idx], t.uv_prev[idx], t.ur_prev[idx], prev.cal.K, prev.cal.baseline)
    return P_b[:, :2]


def model_vs_ba(run, sites, sigma_p_px: float = 1.0 / 3.0, sigma_theta_px: float = 3.0) -> list:
    """One dict per ``ok`` site pair: n tie points, model sigma (m), BA marginal sigma (m), BA actual
    horizontal error of the step (m), step length (m). ``sites`` the read traverse's Site records."""
    from vo.errorprop.crosssite import CrossSiteConfig as ModelConfig, cross_site_accuracy
    rows = []
    for r in run.results:
        if r.status != "ok" or r.ties is None:
            continue
        k = r.index
        prev = sites[k - 1]
        lm = pair_layout(prev, r)
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
