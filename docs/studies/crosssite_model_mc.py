"""Seed 001's error model (eq. 9-13) against the cross-site BA over Monte Carlo runs.

One rendered site pair (campus scene, ``yutu-navcam``, 3 pans per site, the pair of
tests/test_crosssite_rendered.py: site 1 6 m ahead and 0.5 m left of site 0, turned 5.7 deg),
rendered once with depth. Per run ``r`` (stream ``default_rng([SEED_TAG, r])``): Gaussian image noise
on every image (``--image-sigma`` grey levels), the dead-reckoning prior of site 1 drawn from its
covariance, and optionally a pan error per pointing (``--mast-deg``, the rendered pose is the true
one, the localizer gets the commanded one). Each run localizes site 1 against site 0 and records:

* the site-1 position error against truth in site 0's frame, split along-track (site 0 -> 1),
  cross-track (left) and vertical;
* the BA's Marginals covariance (same axes) and its NEES;
* the eq. 9-13 prediction from that run's tie layout (eq. 2 inliers intersected at site 0) with the
  sigma_p and sigma_theta measured in that run against the exact correspondences (rendered depth):
  sigma_p the robust std of the ZNCC + LSM disparity error at site 0, sigma_theta ``atan(s / f)``
  with ``s`` the robust std of the cross-site transfer error (current tie pixel minus the previous
  pixel moved with depth and true poses) scaled by ``z_cur / z_prev`` (the tie's lateral error seen
  from site 0, where eq. 8 puts sigma_theta); the ties are those that agree with the BA pose
  (:func:`vo.crosssite.model_check.ba_ties`). Variants: the paper's values (1/3 px, 3 px); the current
  site's stereo errors added; the same with a rigid transform instead of the similarity.

Prints the table and writes ``figures/crosssite_model_mc/model_mc.png`` and ``runs_<first>.csv``.

    MUJOCO_GL=egl nice -n 5 .venv/bin/python docs/studies/crosssite_model_mc.py --runs 30 --first 0
    MUJOCO_GL=egl nice -n 5 .venv/bin/python docs/studies/crosssite_model_mc.py --runs 30 --first 1000  # held out
"""
from __future__ import annotations

import argparse
import csv
import os
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402
from scipy.stats import chi2  # noqa: E402

from rigs.geometry import inv_T, make_T, rot_z  # noqa: E402
from vo.crosssite import CrossSiteConfig, Site, StereoCal, StereoPair, localize_site  # noqa: E402
from vo.crosssite.model_check import (axis_sigmas, ba_ties, model_covariance, pair_layout,  # noqa: E402
                                      robust_sigma, tie_errors_vs_depth, track_axes)
from vo.crosssite.types import mast_T_b_c  # noqa: E402
from rigs.image_noise import add_image_noise  # noqa: E402

SEED_TAG = 0x001C  # the study's stream tag: run r draws from default_rng([SEED_TAG, r])
OUT = Path(__file__).parent / "figures" / "crosssite_model_mc"
PANS_DEG = (-25.0, 0.0, 25.0)
COV_PRIOR = np.diag([0.01 ** 2, 0.01 ** 2, 0.03 ** 2, 0.2 ** 2, 0.2 ** 2, 0.05 ** 2])  # rot_b, trans_b
AXES = ("along", "cross", "vertical")


def render_pair():
    """-> (rig, cal, T_b_mast, T_head_c, T0, T1, [(left, right, depth_left) per pan] x 2 sites)."""
    from rigs.presets import get_rig
    from scenes import SceneConfig, make_scene
    from scenes.routes import point_at
    from sim.render import StereoRenderer
    from sim.rng import scene_streams
    from sim.world import build_world
    rig = get_rig("yutu-navcam")
    T_b_mast = make_T(np.eye(3), (0.3, 0.0, 1.5))
    T_head_c = inv_T(T_b_mast) @ rig.cameras[0].T_b_c_array
    cal = StereoCal(rig.cameras[0].K, rig.T_c0_c1, 1024, 1024)
    sc = make_scene(SceneConfig(name="campus", seed=0), scene_streams(0))
    p = point_at(sc.path_xy, [2.0, 2.3], closed=sc.route.closed)
    t = p[1] - p[0]
    T0 = make_T(rot_z(np.arctan2(t[1], t[0]) - 0.8), (p[0, 0], p[0, 1], 0.0))
    T1 = T0 @ make_T(rot_z(0.1), (6.0, 0.5, 0.0))
    sites = []
    with StereoRenderer(build_world(sc, rig), gray=True, depth=True, show_vehicle=False) as r:
        for T in (T0, T1):
            imgs = []
            for pan in np.radians(PANS_DEG):
                f = r.render(T @ T_b_mast @ make_T(rot_z(pan), np.zeros(3)) @ inv_T(T_b_mast))
                imgs.append((f.images[0], f.images[1], f.depth[0]))
            sites.append(imgs)
    return cal, T_b_mast, T_head_c, T0, T1, sites


def make_sites(rendered, rng, image_sigma, mast_deg):
    """Site records for one run: noisy images, commanded mast angles (true + error), drawn prior."""
    import gtsam
    cal, T_b_mast, T_head_c, T0, T1, sites = rendered
    out = []
    for s, imgs in enumerate(sites):
        pairs = []
        for pan_deg, (L, R, _) in zip(PANS_DEG, imgs):
            pan_cmd = np.radians(pan_deg) + np.radians(mast_deg) * rng.standard_normal() if mast_deg > 0 else np.radians(pan_deg)
            pairs.append(StereoPair(add_image_noise(L, image_sigma, rng), add_image_noise(R, image_sigma, rng),
                                    mast_T_b_c(T_b_mast, pan_cmd, 0.0, T_head_c), pan_cmd))
        out.append(pairs)
    xi = rng.multivariate_normal(np.zeros(6), COV_PRIOR)
    prev = Site(0, 0, out[0], cal, T0, COV_PRIOR)
    cur = Site(1, 1, out[1], cal, T1 @ gtsam.Pose3.Expmap(xi).matrix(), COV_PRIOR)
    return prev, cur


def one_run(rendered, r, args, cfg) -> dict:
    cal, _, _, T0, T1, sites = rendered
    rng = np.random.default_rng([SEED_TAG, r])
    prev, cur = make_sites(rendered, rng, args.image_sigma, args.mast_deg)
    t0 = time.perf_counter()
    res = localize_site(prev, T0, cur, cfg)
    row = {"run": r, "status": res.status, "time_s": round(time.perf_counter() - t0, 1)}
    if res.status != "ok":
        return row
    return measure(row, prev, cur, res, T0, T1, [d for _, _, d in sites[0]], cal, cfg)


def axes_error(T0, T1):
    """-> f(T_w_b, cov=None): (position error (3,) of ``T_w_b`` against ``T1`` along / cross / vertical in
    site 0's frame, the position block of ``cov`` (gtsam body tangent) on the same axes or None)."""
    R0 = T0[:3, :3]
    A = np.eye(3)
    A[:2, :2] = track_axes((inv_T(T0) @ T1)[:2, 3])        # rows: along, cross, vertical in site 0's frame

    def f(T_w_b, cov=None):
        e = A @ R0.T @ (T_w_b[:3, 3] - T1[:3, 3])
        if cov is None:
            return e, None
        Rh = T_w_b[:3, :3]
        return e, A @ R0.T @ Rh @ cov[3:, 3:] @ Rh.T @ R0 @ A.T
    return f


def rms(x) -> float:
    """Root mean square (about zero) of the finite values of ``x``: the plain estimate next to the robust one."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x ** 2))) if x.size else float("nan")


def measure(row, prev, cur, res, T0, T1, depths0, cal, cfg, diagnose=None) -> dict:
    """``row`` updated with one ``ok`` localization's errors against truth (``T1``), its BA covariance,
    NEES and the eq. 9-13 predictions from its tie layout (``depths0`` the site-0 left depth per pair),
    with robust (MAD) and plain (RMS) sigma_p / sigma_theta; ``diagnose(row, axes_err)``, if given,
    adds its own columns (``crosssite_model_mc_ties.diagnose``)."""
    cur_xy = (inv_T(T0) @ T1)[:2, 3]
    axes_err = axes_error(T0, T1)
    e, C = axes_err(res.T_w_b, res.cov)                     # error and BA position covariance, same axes
    import gtsam
    xi = gtsam.Pose3.Logmap(gtsam.Pose3(res.T_w_b).between(gtsam.Pose3(T1)))
    idx = ba_ties(prev, cur, res, T0, cfg.pnp_reproj_px)
    d_prev, d_cur, transfer, at_prev = tie_errors_vs_depth(prev, cur, res, T0, T1, depths0, idx)
    sp, spc, st = robust_sigma(d_prev), robust_sigma(d_cur), robust_sigma(at_prev[:, 0])
    layout = pair_layout(prev, res, idx)
    M_meas = model_covariance(layout, cur_xy, cal.f, cal.baseline, sp, st)
    M_two = model_covariance(layout, cur_xy, cal.f, cal.baseline, sp, st, sigma_p_cur_px=spc)
    M_paper = model_covariance(layout, cur_xy, cal.f, cal.baseline, 1 / 3, 3.0)
    M_rigid = model_covariance(layout, cur_xy, cal.f, cal.baseline, sp, st, sigma_p_cur_px=spc, scale=False)
    sp_rms, st_rms = rms(d_prev), rms(at_prev[:, 0])
    M_rms = model_covariance(layout, cur_xy, cal.f, cal.baseline, sp_rms, st_rms)
    row["sigma_p_rms_px"], row["sigma_theta_rms_px"] = sp_rms, st_rms
    row["rmsmodel_along"], row["rmsmodel_cross"] = axis_sigmas(M_rms, cur_xy)
    row.update(n_ties=len(layout), n_eq2=int(res.ties.inlier.sum()), n_ba=res.stats.get("n_ba_points", 0),
               sigma_p_px=sp, sigma_p_cur_px=spc, sigma_theta_px=st, sigma_transfer_px=robust_sigma(transfer[:, 0]),
               ba_yaw_deg=float(np.degrees(np.sqrt(res.cov[2, 2]))),
               median_range_m=float(np.median(np.hypot(*layout.T))),
               nees_pos=float(e @ np.linalg.solve(C, e)), nees_pose=float(xi @ np.linalg.solve(res.cov, xi)))
    for k, ax in enumerate(AXES):
        row[f"err_{ax}"] = float(e[k])
        row[f"ba_{ax}"] = float(np.sqrt(C[k, k]))
    row["model_along"], row["model_cross"] = axis_sigmas(M_meas, cur_xy)
    row["two_along"], row["two_cross"] = axis_sigmas(M_two, cur_xy)
    row["rigid_along"], row["rigid_cross"] = axis_sigmas(M_rigid, cur_xy)
    row["paper_along"], row["paper_cross"] = axis_sigmas(M_paper, cur_xy)
    row["err_yaw_deg"] = float(np.degrees(xi[2]))
    for k, name in enumerate(("rx", "ry", "rz")):           # rotation error and BA sigma, site-1 body axes
        row[f"err_{name}_mdeg"] = float(np.degrees(xi[k]) * 1e3)
        row[f"ba_{name}_mdeg"] = float(np.degrees(np.sqrt(res.cov[k, k])) * 1e3)
    row["nees_rot"] = float(xi[:3] @ np.linalg.solve(res.cov[:3, :3], xi[:3]))
    row["ba_rms_px"] = float(res.stats.get("ba_rms_px", float("nan")))
    if diagnose is not None:
        diagnose(row, axes_err)
    return row


def std_ci(x, level=0.95) -> tuple:
    """Sample std (about the sample mean) and its chi2 confidence interval."""
    x = np.asarray(x, float)
    n, s = len(x), float(np.std(x, ddof=1))
    lo, hi = chi2.ppf([(1 + level) / 2, (1 - level) / 2], n - 1)
    return s, s * np.sqrt((n - 1) / lo), s * np.sqrt((n - 1) / hi)


def summarize(rows) -> dict:
    ok = [r for r in rows if r["status"] == "ok"]
    n = len(ok)
    col = lambda k: np.array([r[k] for r in ok])  # noqa: E731
    out = {"n_ok": n, "n_runs": len(rows), "axes": {}}
    err = np.c_[col("err_along"), col("err_cross"), col("err_vertical")]
    for k, ax in enumerate(AXES + ("norm",)):
        if ax == "norm":
            x = np.linalg.norm(err - err.mean(0), axis=1)
            s = float(np.sqrt(np.mean(x ** 2) * n / (n - 1)))
            boot = np.random.default_rng([SEED_TAG, 9999]).choice(x, (2000, n))
            lo, hi = np.percentile(np.sqrt(np.mean(boot ** 2, axis=1) * n / (n - 1)), [2.5, 97.5])
            mean, rms = float(np.linalg.norm(err.mean(0))), float(np.sqrt(np.mean(np.sum(err ** 2, 1))))
            ba = float(np.sqrt(np.mean(col("ba_along") ** 2 + col("ba_cross") ** 2 + col("ba_vertical") ** 2)))
            model = float(np.sqrt(np.mean(col("model_along") ** 2 + col("model_cross") ** 2)))
            two = float(np.sqrt(np.mean(col("two_along") ** 2 + col("two_cross") ** 2)))
            rigid = float(np.sqrt(np.mean(col("rigid_along") ** 2 + col("rigid_cross") ** 2)))
            paper = float(np.sqrt(np.mean(col("paper_along") ** 2 + col("paper_cross") ** 2)))
        else:
            s, lo, hi = std_ci(err[:, k])
            mean, rms = float(err[:, k].mean()), float(np.sqrt(np.mean(err[:, k] ** 2)))
            ba = float(np.sqrt(np.mean(col(f"ba_{ax}") ** 2)))
            model = float(np.sqrt(np.mean(col(f"model_{ax}") ** 2))) if ax != "vertical" else float("nan")
            two = float(np.sqrt(np.mean(col(f"two_{ax}") ** 2))) if ax != "vertical" else float("nan")
            rigid = float(np.sqrt(np.mean(col(f"rigid_{ax}") ** 2))) if ax != "vertical" else float("nan")
            paper = float(np.sqrt(np.mean(col(f"paper_{ax}") ** 2))) if ax != "vertical" else float("nan")
        out["axes"][ax] = dict(std=s, lo=float(lo), hi=float(hi), mean=mean, rms=rms, ba=ba, model=model, two=two, rigid=rigid,
                               paper=paper)
    nees = col("nees_pos")
    out["nees_pos"] = (float(nees.mean()), *(chi2.ppf([0.025, 0.975], 3 * n) / n))
    out["nees_pose"] = (float(col("nees_pose").mean()), *(chi2.ppf([0.025, 0.975], 6 * n) / n))
    if "nees_rot" in ok[0]:
        out["nees_rot"] = (float(col("nees_rot").mean()), *(chi2.ppf([0.025, 0.975], 3 * n) / n))
        out["rot_mdeg"] = {k: (float(col(f"err_{k}_mdeg").mean()), float(col(f"err_{k}_mdeg").std(ddof=1)),
                               float(np.sqrt(np.mean(col(f"ba_{k}_mdeg") ** 2)))) for k in ("rx", "ry", "rz")}
    for k in ("sigma_p_px", "sigma_p_cur_px", "sigma_theta_px", "sigma_transfer_px", "n_ties", "n_ba", "median_range_m",
              "time_s", "err_yaw_deg", "ba_yaw_deg", "n_eq2"):
        out[k] = (float(np.mean(col(k))), float(np.std(col(k))))
    return out


def print_table(s) -> None:
    print(f"\n{s['n_ok']}/{s['n_runs']} runs ok; ties agreeing with the BA {s['n_ties'][0]:.0f} +- {s['n_ties'][1]:.0f} "
          f"(eq. 2 inliers {s['n_eq2'][0]:.0f}, BA points {s['n_ba'][0]:.0f}),"
          f" median tie range {s['median_range_m'][0]:.1f} m; localize {s['time_s'][0]:.0f} s/run")
    print(f"measured sigma_p {s['sigma_p_px'][0]:.3f} px (site 0; site 1 {s['sigma_p_cur_px'][0]:.3f}), transfer "
          f"sigma {s['sigma_transfer_px'][0]:.3f} px (current image), {s['sigma_theta_px'][0]:.3f} px as azimuth at "
          f"site 0 (sigma_theta); yaw error mean "
          f"{s['err_yaw_deg'][0] * 1e3:.1f} std {s['err_yaw_deg'][1] * 1e3:.1f} mdeg, BA yaw sigma {s['ba_yaw_deg'][0] * 1e3:.1f} mdeg")
    print(f"{'axis':9s} {'mean mm':>8s} {'std mm':>7s} {'95% CI mm':>14s} {'model mm':>9s} {'mod/std':>8s} "
          f"{'2-site mm':>9s} {'2s/std':>7s} {'rigid mm':>8s} {'rg/std':>6s} {'paper mm':>9s} {'BA mm':>7s} {'BA/std':>7s} {'rms mm':>7s}")
    for ax, a in s["axes"].items():
        print(f"{ax:9s} {a['mean'] * 1e3:8.2f} {a['std'] * 1e3:7.2f} {a['lo'] * 1e3:6.2f}-{a['hi'] * 1e3:<7.2f} "
              f"{a['model'] * 1e3:9.2f} {a['model'] / a['std']:8.2f} {a['two'] * 1e3:9.2f} {a['two'] / a['std']:7.2f} "
              f"{a['rigid'] * 1e3:8.2f} {a['rigid'] / a['std']:6.2f} "
              f"{a['paper'] * 1e3:9.1f} {a['ba'] * 1e3:7.2f} "
              f"{a['ba'] / a['std']:7.2f} {a['rms'] * 1e3:7.2f}")
    m, lo, hi = s["nees_pos"]
    print(f"BA position NEES mean {m:.2f} (95% band for 3 dof x {s['n_ok']} runs: {lo:.2f}-{hi:.2f}); "
          f"pose NEES {s['nees_pose'][0]:.2f} ({s['nees_pose'][1]:.2f}-{s['nees_pose'][2]:.2f})")
    if "nees_rot" in s:
        print(f"BA rotation NEES {s['nees_rot'][0]:.2f} ({s['nees_rot'][1]:.2f}-{s['nees_rot'][2]:.2f}); rotation error "
              "mean / std / BA sigma (mdeg, site-1 body x, y, z): " +
              ", ".join(f"{k} {m:.1f} / {sd:.1f} / {b:.1f}" for k, (m, sd, b) in s["rot_mdeg"].items()))


def plot(s, path: Path, title: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(s["axes"])
    x = np.arange(len(names))
    fig, ax = plt.subplots(figsize=(7, 4))
    a = s["axes"]
    ax.errorbar(x - 0.15, [a[k]["std"] * 1e3 for k in names],
                yerr=[[(a[k]["std"] - a[k]["lo"]) * 1e3 for k in names], [(a[k]["hi"] - a[k]["std"]) * 1e3 for k in names]],
                fmt="o", color="k", capsize=4, label="measured spread (95% CI)")
    ax.plot(x, [a[k]["model"] * 1e3 for k in names], "s", color="tab:blue", label="eq. 9-13, measured sigma_p, sigma_theta")
    ax.plot(x + 0.05, [a[k]["two"] * 1e3 for k in names], "D", color="tab:green",
            label="eq. 9-13 + current-site stereo errors")
    ax.plot(x + 0.1, [a[k]["rigid"] * 1e3 for k in names], "v", color="tab:purple",
            label="same, rigid (no scale parameter)")
    ax.plot(x + 0.15, [a[k]["ba"] * 1e3 for k in names], "^", color="tab:orange", label="BA Marginals")
    ax.plot(x, [a[k]["rms"] * 1e3 for k in names], "x", color="tab:red", label="RMS error (incl. mean)")
    ax.set_xticks(x, names)
    ax.set_ylabel("1-sigma of the site-1 position (mm)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_rows(rows, path: Path) -> None:
    """Per-run rows as CSV (union of the keys; ``run`` first)."""
    keys = sorted({k for r in rows for k in r}, key=lambda k: (k != "run", k))
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, keys)
        w.writeheader()
        w.writerows(rows)


def read_rows(path: Path) -> list:
    """Rows written by :func:`write_rows`, numbers back as float (``run`` as int, empty cells dropped)."""
    def value(k, v):
        if k in ("status", "matcher"):
            return v
        return int(v) if k == "run" else float(v)
    with open(path, newline="") as fh:
        return [{k: value(k, v) for k, v in r.items() if v != ""} for r in csv.DictReader(fh)]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--first", type=int, default=0, help="first run index (held-out seeds: 1000)")
    ap.add_argument("--image-sigma", type=float, default=2.0, help="grey levels")
    ap.add_argument("--mast-deg", type=float, default=0.0, help="pan error per pointing, 1-sigma deg")
    ap.add_argument("--asift", action="store_true", help="ASIFT instead of SIFT (slower)")
    ap.add_argument("--xsite-sigma-px", type=float, default=0.0,
                    help="CrossSiteConfig.ba_xsite_sigma_px; default 0, the BA weighted by "
                         "sigma_p alone, as in the tables (the product default is 1)")
    args = ap.parse_args(argv)
    cfg = CrossSiteConfig(use_asift=args.asift, ba_xsite_sigma_px=args.xsite_sigma_px)
    OUT.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    rendered = render_pair()
    print(f"rendered 2 sites x {len(PANS_DEG)} pairs in {time.perf_counter() - t0:.0f} s")
    rows = []
    for r in range(args.first, args.first + args.runs):
        rows.append(one_run(rendered, r, args, cfg))
        print({k: (round(v, 4) if isinstance(v, float) else v) for k, v in rows[-1].items()
               if k in ("run", "status", "n_ties", "err_along", "err_cross", "err_vertical", "nees_pos", "time_s")},
              flush=True)
    tag = f"{args.first}-{args.first + args.runs - 1}" + (f"_mast{args.mast_deg:g}" if args.mast_deg else "") + \
        ("_asift" if args.asift else "")
    write_rows(rows, OUT / f"runs_{tag}.csv")
    s = summarize(rows)
    print_table(s)
    plot(s, OUT / f"model_mc_{tag}.png", f"campus pair, 6 m, runs {tag}, image sigma {args.image_sigma:g}, "
         f"{'ASIFT' if args.asift else 'SIFT'}")


if __name__ == "__main__":
    main()
