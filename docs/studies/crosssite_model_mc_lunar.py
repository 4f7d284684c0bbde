"""Seed 001's error model (eq. 9-13) against the cross-site BA over Monte Carlo runs: a lunar site pair.

The pair is leg 0 -> 1 of the ``yutu-traverse`` scenario (``--traverse-seed``, default 0): lunar scene
with its sun, ``rover`` with ``yutu-navcam`` on the pan-tilt mast (head 1.5 m above the body origin,
20 deg down), 7 pointings per site 20 deg apart (-60..+60 deg), sites 0 and 1 at their true rest poses
from :func:`sim.traverse_plan.plan`. Both panoramas are rendered once, with depth, as the traverse writer
renders them (grey from RGB, the scenario's supersampling, rover hidden); ``--cache`` keeps them in an
``.npz`` for later invocations.

Per run ``r`` one generator, ``default_rng([SEED_TAG, r])``, draws: with ``--mast-deg``, a pan and a
tilt error per pointing (the images are rendered at the true angles, the localizer gets the commanded
ones); Gaussian image noise on both images of the pointing (``--image-sigma``, default the
scenario's ``noise.image_sigma``); then the site-1 prior error. The localizer is given the leg prior the traverse localizer
puts on a leg, :func:`vo.crosssite.localizer.leg_model_cov` (``prior_leg_fraction`` 15 % of the leg per
translation axis, ``prior_rot_sigma_rad`` 0.03 rad per rotation axis; the EKF's own leg covariance,
which :func:`~vo.crosssite.localizer.localize_traverse` adds, is left out). The error is drawn from
that covariance with roll, pitch and height at 0.01 rad and 0.05 m (:func:`levelled`: the rover's
IMU levels it and it stands on the ground; 15 % of the leg on height and 0.03 rad on roll and pitch
are a floor for the gate, not errors a dead reckoning makes), or with ``--full-leg-draw`` from the
whole leg prior. The localizer is the
product default :class:`vo.crosssite.CrossSiteConfig` (forward-forward regions, ground-plane zoom,
SIFT first and ASIFT when fewer than 20 eq. 2 ties remain, least-squares refinement of the cross-site
ties, at least ``min_ba_ties`` ties for the BA); ``--xsite-lsm 0`` and ``--min-ba-ties 6`` give the
localizer without the refinement and without the minimum count. Every run is measured as in
``crosssite_model_mc.py`` (:func:`crosssite_model_mc.measure`) plus the tie diagnostics of
``crosssite_model_mc_ties.py`` (each BA tie against its exact observations, the BA solved again with
single error components and with the cross-site matching error in its weights), and the rows are
written after every run, so an interrupted invocation still leaves a table (``--table CSV`` prints it
again). Variants: ``--asift-fallback 0`` (ASIFT in every run), ``--mast-sigma-deg`` (soft mast
constraints in the BA). Outputs go to ``docs/studies/figures/crosssite_model_mc/`` (``--out``: another
directory; ``--suffix``: appended to the names).
``--ties-dir`` keeps every run's tie set; ``--from-ties CSV`` measures the
runs of that CSV again from their saved ties, without matching, with this invocation's BA settings.

    MUJOCO_GL=egl OPENBLAS_NUM_THREADS=1 nice -n 10 .venv/bin/python docs/studies/crosssite_model_mc_lunar.py \\
        --runs 20 --first 1000 --cache /tmp/lunar_pair.npz
    ... --runs 20 --first 1000 --mast-deg 0.05 --cache /tmp/lunar_pair.npz --ties-dir /tmp/lunar_ties/mast
    ... --runs 20 --first 1000 --mast-deg 0.05 --mast-sigma-deg 0.05 --cache /tmp/lunar_pair.npz \
        --ties-dir /tmp/lunar_ties/mast --from-ties docs/studies/figures/crosssite_model_mc/runs_lunar_1000-1019_mast0.05.csv
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).parent))

import numpy as np  # noqa: E402

import crosssite_model_mc as mc  # noqa: E402
import crosssite_model_mc_ties as ties  # noqa: E402
from vo.crosssite import CrossSiteConfig, Site, StereoCal, StereoPair, localize_site  # noqa: E402
from vo.crosssite.localizer import leg_model_cov  # noqa: E402
from vo.crosssite.types import mast_T_b_c  # noqa: E402
from rigs.image_noise import add_image_noise  # noqa: E402

SEED_TAG = 0x001D  # the lunar variant's stream tag (the campus study uses 0x001C)
SCENARIO = "yutu-traverse"
# draw of the prior error on roll, pitch (rad) and height (m), tangent indices 0, 1, 5: IMU-levelled
# attitude and a rover on the ground, the campus study's values
LEVELLED_SIGMA = {0: 0.01, 1: 0.01, 5: 0.05}
MAST_SIGMA_M = 0.001  # soft mast constraints (--mast-sigma-deg): translation sigma of a pointing's camera mount


def render_pair(traverse_seed: int) -> dict:
    """Leg 0 -> 1 of ``yutu-traverse``: poses, mast model, calibration and the rendered panoramas."""
    from sim.render import StereoRenderer
    from sim.scenarios import get_scenario, traverse_scenarios
    from sim.traverse_plan import plan
    from sim.vehicles.rover import MastHead
    from sim.world import build_world
    from rigs.image import to_gray
    config = get_scenario(SCENARIO, seed=traverse_seed)
    tcfg = traverse_scenarios()[SCENARIO]
    tp = plan(config, tcfg)
    head = MastHead.from_rig(config.rig)
    pans = np.radians(tcfg.pans_deg())
    world = build_world(tp.scene, config.rig, vehicle="rover")
    left, right, depth = [], [], []
    with StereoRenderer(world, config.rig, depth=True, supersample=config.render.supersample,
                        show_vehicle=False) as cam:
        for k in (0, 1):
            for pan in pans:
                head.set_pointing(world, pan, head.tilt0_rad)
                f = cam.render(tp.T_w_b_sites[k])
                left.append(to_gray(f.images[0]))
                right.append(to_gray(f.images[1]))
                depth.append(f.depth[0])
    cam0 = config.rig.cameras[0]
    return dict(T0=tp.T_w_b_sites[0], T1=tp.T_w_b_sites[1], pans=pans, tilt0=head.tilt0_rad,
                T_b_mast=head.T_b_mast, T_head_c0=head.T_head_c[0], K=cam0.K, T_c0_c1=config.rig.T_c0_c1,
                size=np.array([cam0.width, cam0.height]), image_sigma=config.noise.image_sigma,
                left=np.array(left), right=np.array(right), depth=np.array(depth, np.float32))


def load_pair(cache, traverse_seed: int) -> dict:
    """The rendered pair from ``cache`` (an ``.npz`` of :func:`render_pair`) or rendered (and cached)."""
    if cache and Path(cache).is_file():
        with np.load(cache) as z:
            return {k: z[k] for k in z.files}
    pair = render_pair(traverse_seed)
    if cache:
        np.savez(cache, **pair)
    return pair


def levelled(cov: np.ndarray) -> np.ndarray:
    """The leg prior with roll, pitch and height at the levelled values of ``LEVELLED_SIGMA``: the prior
    error is drawn from this (horizontal position and yaw keep the leg prior's sigma)."""
    out = np.array(cov, float)
    for k, sd in LEVELLED_SIGMA.items():
        out[k, :], out[:, k] = 0.0, 0.0
        out[k, k] = sd ** 2
    return out


def make_sites(pair: dict, rng, image_sigma: float, mast_deg: float, cfg: CrossSiteConfig,
               full_leg_draw: bool = False):
    """Site records for one run: noisy images, commanded mast angles (true + error), drawn prior."""
    import gtsam
    n = len(pair["pans"])
    W, H = (int(v) for v in pair["size"])
    cal = StereoCal(pair["K"], pair["T_c0_c1"], W, H)
    out = []
    for s in (0, 1):
        pairs = []
        for j, pan in enumerate(pair["pans"]):
            e_pan, e_tilt = np.radians(mast_deg) * rng.standard_normal(2) if mast_deg > 0 else (0.0, 0.0)
            pan_cmd, tilt_cmd = float(pan) + e_pan, float(pair["tilt0"]) + e_tilt
            k = s * n + j
            pairs.append(StereoPair(add_image_noise(pair["left"][k], image_sigma, rng),
                                    add_image_noise(pair["right"][k], image_sigma, rng),
                                    mast_T_b_c(pair["T_b_mast"], pan_cmd, tilt_cmd, pair["T_head_c0"]),
                                    pan_cmd, tilt_cmd))
        out.append(pairs)
    T0, T1 = pair["T0"], pair["T1"]
    cov = leg_model_cov(SimpleNamespace(T_w_b_prior=T0), SimpleNamespace(T_w_b_prior=T1), cfg)
    xi = rng.multivariate_normal(np.zeros(6), cov if full_leg_draw else levelled(cov))
    prev = Site(0, 0, out[0], cal, T0, cov)
    cur = Site(1, 1, out[1], cal, T1 @ gtsam.Pose3.Expmap(xi).matrix(), cov)
    return prev, cur


def one_run(pair: dict, r: int, image_sigma: float, mast_deg: float, cfg: CrossSiteConfig,
            full_leg_draw: bool = False, ties_dir=None, from_row=None) -> dict:
    rng = np.random.default_rng([SEED_TAG, r])
    prev, cur = make_sites(pair, rng, image_sigma, mast_deg, cfg, full_leg_draw)
    t0 = time.perf_counter()
    if from_row is not None:   # --from-ties: the saved tie set, no matching
        if from_row["status"] != "ok":
            return from_row
        res = ties.rebuild_result(prev, pair["T0"], cur, Path(ties_dir) / f"ties_{r}.npz", cfg)
        res.stats["matcher"] = from_row.get("matcher", "")
        row = {k: from_row[k] for k in ("run", "status", "time_s", "n_eq2_all") if k in from_row}
        row["status"] = res.status
    else:
        res = localize_site(prev, pair["T0"], cur, cfg)
        row = {"run": r, "status": res.status, "time_s": round(time.perf_counter() - t0, 1),
               "n_eq2_all": int(res.ties.inlier.sum()) if res.ties is not None else 0}
    if res.status != "ok":
        return row
    if ties_dir and from_row is None:   # the tie set, for BA-only analyses of the run without matching again
        t = res.ties
        np.savez(Path(ties_dir) / f"ties_{r}.npz", **{k: getattr(t, k) for k in (
            "pair_prev", "uv_prev", "pair_cur", "uv_cur", "ur_prev", "ur_cur", "stereo_ok", "inlier")})
    n = len(pair["pans"])
    row["matcher"] = res.stats.get("matcher", "")
    depths0 = list(pair["depth"][:n])
    mounts = [mast_T_b_c(pair["T_b_mast"], float(p), float(pair["tilt0"]), pair["T_head_c0"]) for p in pair["pans"]]

    def diagnose(row, axes_err):
        ties.diagnose(row, prev, cur, res, pair["T0"], pair["T1"], depths0, cfg, [mounts, mounts], axes_err)
    return mc.measure(row, prev, cur, res, pair["T0"], pair["T1"], depths0, prev.cal, cfg, diagnose)


def report(rows, path_png: Path, title: str) -> None:
    """Table and figure, when at least 2 runs are ``ok``."""
    if sum(r["status"] == "ok" for r in rows) < 2:
        print(f"{len(rows)} runs, fewer than 2 ok: no table")
        return
    s = mc.summarize(rows)
    mc.print_table(s)
    ties.print_diagnostics(rows)
    mc.plot(s, path_png, title)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--first", type=int, default=0, help="first run index (held-out seeds: 1000)")
    ap.add_argument("--image-sigma", type=float, default=None, help="grey levels (default: the scenario's)")
    ap.add_argument("--mast-deg", type=float, default=0.0, help="pan and tilt error per pointing, 1-sigma deg")
    ap.add_argument("--traverse-seed", type=int, default=0, help="seed of the yutu-traverse scenario")
    ap.add_argument("--cache", default=None, help=".npz of the rendered pair (read if present, else written)")
    ap.add_argument("--full-leg-draw", action="store_true",
                    help="draw the prior error from the whole leg prior (roll, pitch, height too)")
    ap.add_argument("--asift-fallback", type=int, default=None,
                    help="CrossSiteConfig.asift_fallback_ties (default the product's; 0: ASIFT alone, in every run)")
    ap.add_argument("--mast-sigma-deg", type=float, default=0.0,
                    help="soft mast constraints: CrossSiteConfig.mast_sigma_rad in deg (0: hard, eq. 5)")
    ap.add_argument("--xsite-sigma-px", type=float, default=0.0,
                    help="CrossSiteConfig.ba_xsite_sigma_px; default 0, the BA weighted by "
                         "sigma_p alone, as in the tables (the product default is 1)")
    ap.add_argument("--ties-dir", default=None, help="write each ok run's tie set here (ties_<run>.npz)")
    ap.add_argument("--from-ties", default=None, metavar="CSV",
                    help="no matching: rebuild every run of this runs CSV from --ties-dir (BA with this invocation's "
                         "configuration) and measure again")
    ap.add_argument("--table", default=None, help="only print the table of this runs CSV")
    ap.add_argument("--xsite-lsm", type=int, choices=(0, 1), default=None,
                    help="CrossSiteConfig.xsite_lsm (default the product's): LSM refinement of the cross-site ties")
    ap.add_argument("--min-ba-ties", type=int, default=None, help="CrossSiteConfig.min_ba_ties (default the product's)")
    ap.add_argument("--out", default=None, help="directory of the CSV and PNG (default: figures/crosssite_model_mc)")
    ap.add_argument("--suffix", default="", help="appended to the output names")
    args = ap.parse_args(argv)
    if args.from_ties and not args.ties_dir:
        ap.error("--from-ties needs --ties-dir (where the runs' tie sets were saved)")
    out = Path(args.out) if args.out else mc.OUT
    out.mkdir(parents=True, exist_ok=True)
    if args.table:
        rows = mc.read_rows(Path(args.table))
        report(rows, Path(args.table).with_suffix(".png"), f"lunar pair, {Path(args.table).stem}")
        return
    cfg = CrossSiteConfig(ba_xsite_sigma_px=args.xsite_sigma_px)
    if args.asift_fallback is not None:
        cfg = replace(cfg, asift_fallback_ties=args.asift_fallback)
    if args.xsite_lsm is not None:
        cfg = replace(cfg, xsite_lsm=bool(args.xsite_lsm))
    if args.min_ba_ties is not None:
        cfg = replace(cfg, min_ba_ties=args.min_ba_ties)
    if args.mast_sigma_deg > 0:   # the mast translation is known to MAST_SIGMA_M
        cfg = replace(cfg, mast_sigma_rad=float(np.radians(args.mast_sigma_deg)), mast_sigma_m=MAST_SIGMA_M)
    t0 = time.perf_counter()
    pair = load_pair(args.cache, args.traverse_seed)
    sigma = float(pair["image_sigma"]) if args.image_sigma is None else args.image_sigma
    leg = pair["T1"][:3, 3] - pair["T0"][:3, 3]
    print(f"{len(pair['pans'])} + {len(pair['pans'])} pointings ready in {time.perf_counter() - t0:.0f} s; "
          f"leg {np.linalg.norm(leg):.2f} m, image sigma {sigma:g}")
    tag = f"lunar_{args.first}-{args.first + args.runs - 1}" + (f"_mast{args.mast_deg:g}" if args.mast_deg else "") + \
        ("_fullleg" if args.full_leg_draw else "") + \
        (f"_asift{args.asift_fallback}" if args.asift_fallback is not None else "") + \
        (f"_soft{args.mast_sigma_deg:g}" if args.mast_sigma_deg > 0 else "") + args.suffix
    old = {r["run"]: r for r in mc.read_rows(Path(args.from_ties))} if args.from_ties else {}
    if args.ties_dir:
        Path(args.ties_dir).mkdir(parents=True, exist_ok=True)
    rows = []
    for r in range(args.first, args.first + args.runs):
        rows.append(one_run(pair, r, sigma, args.mast_deg, cfg, args.full_leg_draw, args.ties_dir, old.get(r)))
        mc.write_rows(rows, out / f"runs_{tag}.csv")
        print({k: (round(v, 4) if isinstance(v, float) else v) for k, v in rows[-1].items()
               if k in ("run", "status", "n_ties", "err_along", "err_cross", "err_vertical", "nees_pos", "time_s")},
              flush=True)
    report(rows, out / f"model_mc_{tag}.png", f"lunar pair (yutu-traverse leg 0-1), 7+7 pointings, runs {tag}, "
           f"image sigma {sigma:g}, mast {args.mast_deg:g} deg")


if __name__ == "__main__":
    main()
