"""Per-run tie diagnostics for the cross-site Monte Carlo studies (``crosssite_model_mc*.py``).

For one ``ok`` localization: the tie set the BA was given (the localizer's stage 6 rebuilt:
eq. 2 inliers, subsampled to ``max_ba_points``, intersected at the previous site, kept where they
agree with the resection), each tie's exact observations from the previous site's rendered depth
and the true poses, and the BA solved again (same graph, same settings) on observations in which
chosen error components are replaced by their true values:

* ``true``: every observation exact (checks the truth: the pose error must vanish);
* ``dprev``: only the previous site's stereo disparity error kept (``u_r`` at site 0);
* ``xsite``: only the cross-site matching error kept (the current left pixel, u and v);
* ``dcur``: only the current site's disparity error kept;
* ``drop1``: the actual observations without the ties whose cross-site or disparity error
  exceeds 1 px (when at least ``min_tie_points`` remain);
* ``xs<s>``: the actual observations with the cross-site matching error ``s`` px (``XSITE_PX``) in
  the BA's observation covariance of the current site (:func:`vo.crosssite.bundle.stereo_noise`).

Truth: the previous left pixel is the tie's reference. Its depth is interpolated bilinearly in
inverse depth (exact on a plane, where 1/z is affine in the pixel) from the 4 neighbouring depth
pixels; a tie whose 4 neighbours differ by more than ``EDGE_REL`` in depth (an occlusion edge)
has no truth and keeps its actual observations in every replay.
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import inv_T
from vo.errors import VoError

EDGE_REL = 0.05        # 4-neighbour depth spread (relative) above which a tie sits on an occlusion edge
COMPONENTS = ("dprev", "xsite", "dcur")
XSITE_PX = (1.0, 1.5, 2.0, 3.0)   # cross-site matching sigmas of the weighted replays (3 px: seed 001's ASIFT figure)


def ba_tie_set(prev, T0, cur, res, cfg) -> tuple:
    """(indices into ``res.ties`` of the ties the BA was given, their points intersected at the
    previous site (n,3) in w, the resected initial pose): the localizer's stage 6, deterministic."""
    from vo.crosssite.localizer import resection_inliers, subsample_ties, initial_pose
    t = res.ties
    idx = subsample_ties(np.flatnonzero(t.inlier), cfg.max_ba_points)
    T_init, P_w = initial_pose(cur, T0, prev, t, idx, cfg)
    keep = resection_inliers(cur, T_init, P_w, t, idx, cfg)
    return idx[keep], P_w[keep], T_init


def inv_depth_bilinear(depth: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """(n,) depth at sub-pixel ``uv`` (n,2) from bilinear interpolation of 1/z; NaN outside the image,
    where a neighbour is not finite, or across an occlusion edge (neighbours' spread > ``EDGE_REL``)."""
    H, W = depth.shape
    out = np.full(len(uv), np.nan)
    for m, (u, v) in enumerate(np.asarray(uv, float)):
        u0, v0 = int(np.floor(u)), int(np.floor(v))
        if not (0 <= u0 < W - 1 and 0 <= v0 < H - 1):
            continue
        z4 = depth[v0:v0 + 2, u0:u0 + 2].astype(float)
        if not np.all(np.isfinite(z4)) or z4.min() <= 0 or z4.max() / z4.min() > 1 + EDGE_REL:
            continue
        a, b = u - u0, v - v0
        iz = (1 - b) * ((1 - a) * 1 / z4[0, 0] + a / z4[0, 1]) + b * ((1 - a) / z4[1, 0] + a / z4[1, 1])
        out[m] = 1.0 / iz
    return out


def true_observations(prev, cur, ties, idx, T0, T1, depths0, T_b_c0_true) -> dict:
    """Exact observations of ties ``idx``: ``ur_prev``, ``uv_cur``, ``ur_cur`` (NaN without truth),
    the point's depth at site 0 ``z_prev`` and its horizontal range from site 0 ``range_m``.
    ``T_b_c0_true`` ([site 0 list, site 1 list]) the true camera mounts (the commanded ones differ
    under mast-angle error)."""
    from vo.crosssite.regions import project
    K, f, B = prev.cal.K, prev.cal.f, prev.cal.baseline
    n = len(idx)
    out = {k: np.full(n, np.nan) for k in ("ur_prev", "ur_cur", "z_prev", "z_cur", "range_m")}
    out["uv_cur"] = np.full((n, 2), np.nan)
    uv0 = ties.uv_prev[idx]
    for i in np.unique(ties.pair_prev[idx]):
        s = np.flatnonzero(ties.pair_prev[idx] == i)
        z = inv_depth_bilinear(depths0[i], uv0[s])
        P_c = np.c_[uv0[s], np.ones(len(s))] @ np.linalg.inv(K).T * z[:, None]
        P_w = (T0 @ T_b_c0_true[0][i] @ np.c_[P_c, np.ones(len(s))].T)[:3].T
        out["ur_prev"][s], out["z_prev"][s] = uv0[s, 0] - f * B / z, z
        out["range_m"][s] = np.hypot(*(inv_T(T0) @ np.c_[P_w, np.ones(len(s))].T)[:2])
        for j in np.unique(ties.pair_cur[idx][s]):
            t = s[ties.pair_cur[idx][s] == j]
            uv, zc = project(T1 @ T_b_c0_true[1][j], K, P_w[ties.pair_cur[idx][s] == j])
            good = zc > 0
            out["uv_cur"][t[good]] = uv[good]
            out["ur_cur"][t[good]] = uv[good, 0] - f * B / zc[good]
            out["z_cur"][t[good]] = zc[good]
    return out


def tie_errors(ties, idx, truth) -> dict:
    """Per-tie errors (actual minus exact): ``dprev`` disparity at site 0 (px), ``xsite`` (n,2) the
    current left pixel, ``dcur`` disparity at site 1 (px)."""
    d_act_cur = ties.uv_cur[idx][:, 0] - ties.ur_cur[idx]
    d_true_cur = truth["uv_cur"][:, 0] - truth["ur_cur"]
    return {"dprev": -(ties.ur_prev[idx] - truth["ur_prev"]), "xsite": ties.uv_cur[idx] - truth["uv_cur"],
            "dcur": d_act_cur - d_true_cur}


def compose(ties, idx, truth, keep_actual: tuple):
    """Observations of ties ``idx`` with the error components in ``keep_actual`` actual and the
    others exact (ties without truth stay actual). -> TieObservations."""
    from vo.crosssite.localizer import tie_observations
    from vo.crosssite.ties import TieSet
    ok = np.isfinite(truth["ur_prev"]) & np.all(np.isfinite(truth["uv_cur"]), axis=1)
    uv_cur = ties.uv_cur[idx].copy()
    ur_prev = ties.ur_prev[idx].copy()
    disp_cur = ties.uv_cur[idx][:, 0] - ties.ur_cur[idx]
    if "xsite" not in keep_actual:
        uv_cur[ok] = truth["uv_cur"][ok]
    if "dprev" not in keep_actual:
        ur_prev[ok] = truth["ur_prev"][ok]
    if "dcur" not in keep_actual:
        disp_cur[ok] = (truth["uv_cur"][:, 0] - truth["ur_cur"])[ok]
    n = len(idx)
    t = TieSet(ties.pair_prev[idx], ties.uv_prev[idx], ties.pair_cur[idx], uv_cur, ur_prev=ur_prev,
               ur_cur=uv_cur[:, 0] - disp_cur)
    return tie_observations(t, np.arange(n))


def replay(prev, cur, T0, T_init, P_w, obs, cfg, xsite_sigma_px: float = 0.0):
    """The BA of the localizer on observations ``obs`` (None when gtsam fails); ``xsite_sigma_px`` the
    cross-site matching error of the current-site observations (:mod:`vo.crosssite.bundle`)."""
    from vo.crosssite.bundle import bundle_adjust
    try:
        return bundle_adjust(T0, T_init, [[p.T_b_c0 for p in prev.pairs], [p.T_b_c0 for p in cur.pairs]], obs, P_w,
                             cur.cal.K, cur.cal.baseline, cfg.ba_sigma_px, cfg.ba_huber_k, cfg.mast_sigma_rad,
                             cfg.mast_sigma_m, xsite_sigma_px=xsite_sigma_px)
    except (RuntimeError, VoError):  # gtsam: indeterminant system; too few points after the residual test
        return None


def diagnose(row: dict, prev, cur, res, T0, T1, depths0, cfg, T_b_c0_true, axes_err) -> dict:
    """``row`` updated with the tie-truth counts, the error statistics from the interpolated truth
    (``bl_*``), eq. 9-13 with those sigmas, the BA's a-posteriori sigma and the replays (module doc).
    ``axes_err(T_w_b, cov=None)`` -> (position error (3,) along / cross / vertical, that covariance on
    the same axes or None)."""
    t = res.ties
    idx, P_w, T_init = ba_tie_set(prev, T0, cur, res, cfg)
    truth = true_observations(prev, cur, t, idx, T0, T1, depths0, T_b_c0_true)
    e = tie_errors(t, idx, truth)
    has = tie_statistics(row, e, truth)
    from vo.crosssite.model_check import axis_sigmas, model_covariance, pair_layout
    layout, cur_xy = pair_layout(prev, res, idx), (inv_T(T0) @ T1)[:2, 3]
    for est in ("rms", "mad"):   # eq. 9-13 on the BA's ties with this truth's sigma_p, sigma_theta
        M = model_covariance(layout, cur_xy, prev.cal.f, prev.cal.baseline, row[f"bl_dprev_{est}_px"],
                             row[f"bl_theta_{est}_px"])
        row[f"blmodel_{est}_along"], row[f"blmodel_{est}_cross"] = axis_sigmas(M, cur_xy)
    replays(row, prev, cur, res, T0, T1, cfg, idx, P_w, T_init, truth, axes_err)
    ex = np.linalg.norm(e["xsite"], axis=1)
    good = has & (ex <= 1) & (np.abs(e["dprev"]) <= 1) & (np.abs(e["dcur"]) <= 1)
    if good.sum() >= cfg.min_tie_points:   # drop1: without the ties > 1 px from truth
        from vo.crosssite.localizer import tie_observations
        r = replay(prev, cur, T0, res.T_w_b, P_w[good], tie_observations(t, idx[good]), cfg)
        if r is not None:
            row["drop1_n"] = int(good.sum())
            pose_nees(row, "drop1_", r, axes_err, T1)
    return row


def tie_statistics(row: dict, e: dict, truth: dict) -> np.ndarray:
    """``row`` gets the counts of ties beyond 1, 2, 3 px of truth, their range, and the mean / RMS /
    1.4826 MAD of each error component and of the azimuth error at site 0 (the cross-site u error
    times ``z_cur / z_prev``). -> (n,) bool: ties with truth."""
    ex = np.linalg.norm(e["xsite"], axis=1)
    has = np.isfinite(ex) & np.isfinite(e["dprev"]) & np.isfinite(e["dcur"])
    row.update(n_ba_given=len(ex), n_truth=int(has.sum()))
    for k in (1, 2, 3):
        row[f"n_xsite_gt{k}px"] = int((ex[has] > k).sum())
        row[f"n_disp_gt{k}px"] = int(((np.abs(e["dprev"]) > k) | (np.abs(e["dcur"]) > k))[has].sum())
    for name, sel in (("gt2px", has & (ex > 2)), ("le2px", has & (ex <= 2))):
        row[f"range_xsite_{name}_m"] = float(np.median(truth["range_m"][sel])) if sel.any() else float("nan")
    row["xsite_max_px"] = float(np.max(ex[has])) if has.any() else float("nan")
    theta = e["xsite"][:, 0] * truth["z_cur"] / truth["z_prev"]
    for name, x in (("dprev", e["dprev"]), ("xsite_u", e["xsite"][:, 0]), ("xsite_v", e["xsite"][:, 1]),
                    ("dcur", e["dcur"]), ("theta", theta)):
        x = x[has]
        row[f"bl_{name}_mean_px"] = float(np.mean(x))
        row[f"bl_{name}_rms_px"] = float(np.sqrt(np.mean(x ** 2)))
        row[f"bl_{name}_mad_px"] = float(1.4826 * np.median(np.abs(x - np.median(x))))
    return has


def replays(row: dict, prev, cur, res, T0, T1, cfg, idx, P_w, T_init, truth, axes_err) -> None:
    """``row`` gets: the rebuild check and the BA's a-posteriori sigma0 (redundancy 3N - 6 for N points
    with 2 stereo observations each), the pose error with one error component actual (``rp_*``), and
    the pose, covariance and NEES with the cross-site error in the weights (``xs<s>_*``)."""
    from vo.crosssite.localizer import tie_observations
    t = res.ties
    base = replay(prev, cur, T0, T_init, P_w, compose(t, idx, truth, COMPONENTS), cfg)
    if base is not None:
        row["replay_actual_dpos_mm"] = float(np.linalg.norm(base.T_w_b[:3, 3] - res.T_w_b[:3, 3]) * 1e3)
        N = base.n_points
        row["ba_sigma0_px"] = float(base.rms_px * np.sqrt(6 * N / max(3 * N - 6, 1)))
    for name, keep in (("true", ()), ("dprev", ("dprev",)), ("xsite", ("xsite",)), ("dcur", ("dcur",))):
        r = replay(prev, cur, T0, T_init, P_w, compose(t, idx, truth, keep), cfg)
        for k, ax in enumerate(("along", "cross", "vertical")):
            row[f"rp_{name}_{ax}"] = float(axes_err(r.T_w_b)[0][k]) if r is not None else float("nan")
    for xs in XSITE_PX:
        r = replay(prev, cur, T0, T_init, P_w, tie_observations(t, idx), cfg, xs)
        if r is not None:
            pose_nees(row, f"xs{xs:g}_", r, axes_err, T1)


def pose_nees(row: dict, prefix: str, r, axes_err, T1) -> None:
    """``row`` gets ``<prefix>err_<axis>``, ``<prefix>ba_<axis>`` (m) and the position, rotation and
    pose NEES of the BA result ``r`` against the true pose ``T1``."""
    import gtsam
    err, C = axes_err(r.T_w_b, r.cov)
    for k, ax in enumerate(("along", "cross", "vertical")):
        row[f"{prefix}err_{ax}"], row[f"{prefix}ba_{ax}"] = float(err[k]), float(np.sqrt(C[k, k]))
    xi = gtsam.Pose3.Logmap(gtsam.Pose3(r.T_w_b).between(gtsam.Pose3(T1)))
    row[f"{prefix}nees_pos"] = float(err @ np.linalg.solve(C, err))
    row[f"{prefix}nees_rot"] = float(xi[:3] @ np.linalg.solve(r.cov[:3, :3], xi[:3]))
    row[f"{prefix}nees_pose"] = float(xi @ np.linalg.solve(r.cov, xi))
    for k, name in enumerate(("rx", "ry", "rz")):
        row[f"{prefix}err_{name}_mdeg"] = float(np.degrees(xi[k]) * 1e3)
        row[f"{prefix}ba_{name}_mdeg"] = float(np.degrees(np.sqrt(r.cov[k, k])) * 1e3)


GROSS_PX = 20.0   # a BA tie this far from its truth in the current image is a false match (10x the consensus)


def print_diagnostics(rows, title: str = "all ok runs") -> None:
    """The per-run diagnostics of :func:`diagnose` summed over the ``ok`` runs that have them; again
    without the runs whose BA tie set holds a false match (``xsite_max_px`` > ``GROSS_PX``)."""
    ok = [r for r in rows if r.get("status") == "ok" and "n_ba_given" in r]
    if len(ok) < 2:
        return
    print(f"\n== {title}: {len(ok)} runs ==")
    col = lambda k: np.array([r.get(k, np.nan) for r in ok], float)  # noqa: E731
    sd = lambda k: float(np.nanstd(col(k), ddof=1) * 1e3)  # noqa: E731
    qm = lambda k: float(np.sqrt(np.nanmean(col(k) ** 2)))  # noqa: E731
    axes = ("along", "cross", "vertical")
    print(f"\ntie truth over {len(ok)} runs: BA given {col('n_ba_given').mean():.1f} ties/run "
          f"({col('n_truth').mean():.1f} with truth); stage-6 rebuild reproduces the BA pose within "
          f"{np.nanmax(col('replay_actual_dpos_mm')):.3f} mm")
    print("ties with cross-site error > 1 / 2 / 3 px: " + " / ".join(
        f"{int(col(f'n_xsite_gt{k}px').sum())}" for k in (1, 2, 3)) + f" of {int(col('n_truth').sum())}; "
          f"disparity error > 1 / 2 / 3 px: " + " / ".join(f"{int(col(f'n_disp_gt{k}px').sum())}" for k in (1, 2, 3)) +
          f"; median range of ties > 2 px {np.nanmedian(col('range_xsite_gt2px_m')):.1f} m, "
          f"<= 2 px {np.nanmedian(col('range_xsite_le2px_m')):.1f} m; max {np.nanmax(col('xsite_max_px')):.1f} px")
    print("error statistics (interpolated truth), mean over runs of: mean / RMS / 1.4826 MAD (px)")
    for name in ("dprev", "xsite_u", "xsite_v", "dcur"):
        print(f"  {name:8s} {np.mean(col(f'bl_{name}_mean_px')):+.3f} / {np.mean(col(f'bl_{name}_rms_px')):.3f} / "
              f"{np.mean(col(f'bl_{name}_mad_px')):.3f}")
    print(f"  theta    RMS {np.mean(col('bl_theta_rms_px')):.3f} / MAD {np.mean(col('bl_theta_mad_px')):.3f} "
          f"(nearest-pixel truth, measure(): sigma_p RMS {np.mean(col('sigma_p_rms_px')):.3f} MAD "
          f"{np.mean(col('sigma_p_px')):.3f}, sigma_theta RMS {np.mean(col('sigma_theta_rms_px')):.3f} MAD "
          f"{np.mean(col('sigma_theta_px')):.3f})")
    err = {ax: sd(f"err_{ax}") for ax in axes}
    print("spread std mm (along / cross / vertical): " + " / ".join(f"{err[ax]:.1f}" for ax in axes) +
          "; mean " + " / ".join(f"{np.mean(col(f'err_{ax}')) * 1e3:+.1f}" for ax in axes))
    print("model, interpolated truth, plain / MAD sigma: " + ", ".join(
        f"{ax} {qm(f'blmodel_rms_{ax}') * 1e3:.1f} / {qm(f'blmodel_mad_{ax}') * 1e3:.1f} mm "
        f"({qm(f'blmodel_rms_{ax}') * 1e3 / err[ax]:.2f} / {qm(f'blmodel_mad_{ax}') * 1e3 / err[ax]:.2f} of std); "
        f"per-run RMS z {np.sqrt(np.mean((col(f'err_{ax}') / col(f'blmodel_rms_{ax}')) ** 2)):.2f} / "
        f"{np.sqrt(np.mean((col(f'err_{ax}') / col(f'blmodel_mad_{ax}')) ** 2)):.2f}" for ax in axes[:2]))
    print("model, nearest-pixel truth (measure()), plain sigma: " + ", ".join(
        f"{ax} {qm(f'rmsmodel_{ax}') * 1e3:.1f} mm ({qm(f'rmsmodel_{ax}') * 1e3 / err[ax]:.2f} of std {err[ax]:.1f}; "
        f"MAD model {qm(f'model_{ax}') * 1e3 / err[ax]:.2f})" for ax in axes[:2]))
    print(f"BA sigma0 a posteriori {np.nanmean(col('ba_sigma0_px')):.3f} px (rms {np.nanmean(col('ba_rms_px')):.3f}),"
          " assumed 0.333 px")
    print("replay std mm (along / cross / vertical): actual " + " / ".join(f"{err[ax]:.1f}" for ax in axes))
    for name in ("true", "dprev", "xsite", "dcur"):
        print(f"  {name:6s} " + " / ".join(f"{sd(f'rp_{name}_{ax}'):.1f}" for ax in axes) +
              "   rms " + " / ".join(f"{qm(f'rp_{name}_{ax}') * 1e3:.1f}" for ax in axes))
    from scipy.stats import chi2
    n = len(ok)
    b3, b6 = chi2.ppf([0.025, 0.975], 3 * n) / n, chi2.ppf([0.025, 0.975], 6 * n) / n
    print(f"BA variants over {n} runs: std mm / BA sigma mm (along, cross, vertical); NEES position, rotation "
          f"({b3[0]:.2f}-{b3[1]:.2f}), pose ({b6[0]:.2f}-{b6[1]:.2f})")
    for pre, name in [("", "product BA")] + [(f"xs{x:g}_", f"cross-site {x:g} px") for x in XSITE_PX]:
        if f"{pre}nees_pos" not in ok[0]:
            continue
        print(f"  {name:16s} " + " / ".join(f"{sd(f'{pre}err_{ax}'):.1f}" for ax in axes) + "  BA " +
              " / ".join(f"{qm(f'{pre}ba_{ax}') * 1e3:.1f}" for ax in axes) + "  NEES " +
              " / ".join(f"{np.nanmean(col(f'{pre}nees_{k}')):.2f}" for k in ("pos", "rot", "pose")) +
              "  rot std / BA mdeg " + ", ".join(f"{sd(f'{pre}err_{k}_mdeg') / 1e3:.0f} / {qm(f'{pre}ba_{k}_mdeg'):.0f}"
                                               for k in ("rx", "ry", "rz")))
    d = [r for r in ok if "drop1_n" in r]
    if len(d) >= 2:
        c = lambda k: np.array([r[k] for r in d], float)  # noqa: E731
        lo, hi = chi2.ppf([0.025, 0.975], 3 * len(d)) / len(d)
        print(f"drop ties > 1 px from truth ({len(d)} runs, {c('drop1_n').mean():.1f} ties/run): std " +
              " / ".join(f"{np.std(c(f'drop1_err_{ax}'), ddof=1) * 1e3:.1f}" for ax in axes) + " mm, BA " +
              " / ".join(f"{np.sqrt(np.mean(c(f'drop1_ba_{ax}') ** 2)) * 1e3:.1f}" for ax in axes) +
              f" mm, position NEES {c('drop1_nees_pos').mean():.2f} ({lo:.2f}-{hi:.2f}); same runs, all ties: std " +
              " / ".join(f"{np.std(c(f'err_{ax}'), ddof=1) * 1e3:.1f}" for ax in axes) +
              f" mm, NEES {c('nees_pos').mean():.2f}")
    gross = [r["run"] for r in ok if r.get("xsite_max_px", 0) > GROSS_PX]
    if gross and title == "all ok runs":
        print_diagnostics([r for r in ok if r["run"] not in gross],
                          f"without runs {gross} (a BA tie > {GROSS_PX:g} px from truth)")


def rebuild_result(prev, T0, cur, path, cfg):
    """The SiteResult of a run from its saved tie set (``ties_<run>.npz``): the localizer's stage 6, its
    ``min_ba_ties`` rule and BA on those ties (deterministic: the same pose and covariance)."""
    from vo.crosssite.bundle import bundle_adjust
    from vo.crosssite.localizer import tie_observations
    from vo.crosssite.ties import TieSet
    from vo.crosssite.types import SiteResult
    with np.load(path) as z:
        t = TieSet(**{k: z[k] for k in z.files})
    res = SiteResult(cur.index, "ok", cur.T_w_b_prior, cur.cov_prior, int(t.inlier.sum()), ties=t)
    idx, P_w, T_init = ba_tie_set(prev, T0, cur, res, cfg)
    if len(idx) < cfg.min_ba_ties:   # the localizer's minimum tie count
        return SiteResult(cur.index, "few_tie_points", cur.T_w_b_prior, cur.cov_prior, int(t.inlier.sum()), ties=t)
    b = bundle_adjust(T0, T_init, [[p.T_b_c0 for p in prev.pairs], [p.T_b_c0 for p in cur.pairs]], tie_observations(t, idx),
                      P_w, cur.cal.K, cur.cal.baseline, cfg.ba_sigma_px, cfg.ba_huber_k, cfg.mast_sigma_rad,
                      cfg.mast_sigma_m)
    return SiteResult(cur.index, "ok", b.T_w_b, b.cov, int(t.inlier.sum()),
                      {"n_ba_points": len(idx), "ba_rms_px": round(b.rms_px, 4)}, ties=t)
