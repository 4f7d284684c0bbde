"""Moving objects and stereo VO: where ``klt-pnp`` / ``rop`` drift on ``urban-dynamic`` and why.

Runs an estimator frame by frame on a dataset written with ``--segmentation`` and, per frame, compares
the estimated inter-frame motion with the true one (``groundtruth_cam0``) and labels the features the
estimator used with the true segmentation (:class:`vo.vins.truth_segmentation.FeatureLabels`; the estimator never
sees them):

* ``klt-pnp``: the tracked landmarks and the PnP inliers (fraction on moving actors);
* ``rop``: the four-view tracks it used (fraction on moving actors; on keyframes with the new corners).

Prints the drift (end-point error / true path length), the frames where the largest share of the
end error accrues with their moving-inlier fractions, and the correlation between translation error and
moving-inlier fraction. Usage::

    vo-testbed generate --scenario urban-dynamic --segmentation --out DATA
    python docs/studies/urban_dynamic_vo.py DATA --estimator klt-pnp [--max-frames 300] [--opt KEY=VALUE ...]
    python docs/studies/urban_dynamic_vo.py DATA --estimator klt-pnp --oracle   # PnP on true-static features only
"""
from __future__ import annotations

import argparse

import numpy as np
import yaml

from rigs.geometry import inv_T, rotation_angle
from vo.dataset import open_dataset
from vo.estimators.runner import run_estimator
from vo.vins.truth_segmentation import FeatureLabels

PNP_ESTIMATORS = ("klt-pnp", "orb-pnp")     # estimators with the pnp_observer / pnp_select hooks


def _rop_features(est, log: dict) -> None:
    """Record the current frame's left pixels of the four-view tracks the ROPs used (all count as inliers)."""
    v = getattr(est.klt, "view", None) if est.klt is not None else None
    if v is not None and len(v):
        log["px"] = v.p3[v.ok4].copy()
        log["inl"] = np.ones(len(log["px"]), bool)


def run(dataset_dir: str, estimator: str, max_frames: int | None, options: dict, oracle: bool = False) -> dict:
    """Per frame: status, features, moving fractions, true and estimated step, step errors. A PnP estimator's
    pixels and inlier masks come from its ``pnp_observer`` hook; with ``oracle`` (a function of the current
    frame's true segmentation, its ``pnp_select`` hook) the PnP sees only the features the true
    segmentation calls static: the bound any moving-object rule can reach."""
    ds = open_dataset(dataset_dir)
    labels = FeatureLabels.of(ds)
    T_w_c = ds.groundtruth_cam0().T
    pnp = estimator in PNP_ESTIMATORS
    if oracle and (labels is None or not pnp):
        raise SystemExit("--oracle needs a dataset with --segmentation and a PnP estimator (klt-pnp, orb-pnp)")
    log: dict = {}
    current = {"k": 0, "T_prev": None}
    opts = dict(options)
    if pnp:
        opts["pnp_observer"] = lambda px, inl: log.update(px=px, inl=inl)
        if oracle:
            opts["pnp_select"] = lambda px: ~labels.dynamic(current["k"], px)
    rows = []

    def before(frame):
        log.clear()
        current["k"] = frame.index

    def after(frame, res, est):
        k, T_prev = frame.index, current["T_prev"]
        if estimator == "rop":
            _rop_features(est, log)
        dyn_inl = dyn_all = np.nan
        if labels is not None and "px" in log and len(log["px"]):
            d = labels.dynamic(k, log["px"])
            dyn_all = float(d.mean())
            dyn_inl = float(d[log["inl"]].mean()) if log["inl"].any() else np.nan
        if T_prev is not None:
            T_true = inv_T(T_w_c[k - 1]) @ T_w_c[k]
            T_est = inv_T(T_prev) @ res.T_o_c0
            rows.append((k, res.status, res.n_features, res.n_inliers, dyn_all, dyn_inl,
                         np.linalg.norm(T_true[:3, 3]), np.linalg.norm(T_est[:3, 3]),
                         np.linalg.norm(T_est[:3, 3] - T_true[:3, 3]),
                         np.degrees(rotation_angle(T_true[:3, :3].T @ T_est[:3, :3]))))
        current["T_prev"] = res.T_o_c0.copy()

    n = len(ds) if max_frames is None else min(max_frames, len(ds))
    run_estimator(estimator, ds, opts, progress=False, max_frames=n, before_frame=before, on_frame=after)
    return {"rows": rows, "T_w_c": T_w_c[:n], "est_end": current["T_prev"]}


def report(out: dict) -> None:
    rows = out["rows"]
    k, st, nf, ni, dyn_all, dyn_inl, s_true, s_est, e_t, e_r = (np.array(c, dtype=object) for c in zip(*rows))
    s_true, s_est, e_t, e_r = (np.asarray(a, float) for a in (s_true, s_est, e_t, e_r))
    dyn_all, dyn_inl = np.asarray(dyn_all, float), np.asarray(dyn_inl, float)
    T_w_c = out["T_w_c"]
    path = float(np.sum(np.linalg.norm(np.diff(T_w_c[:, :3, 3], axis=0), axis=1)))
    T_true_end = inv_T(T_w_c[0]) @ T_w_c[-1]
    drift = np.linalg.norm(out["est_end"][:3, 3] - T_true_end[:3, 3]) / path
    R_err = T_true_end[:3, :3].T @ out["est_end"][:3, :3]
    print(f"frames {len(rows) + 1}, path {path:.1f} m, end drift {100 * drift:.2f} %, end orientation error "
          f"{np.degrees(rotation_angle(R_err)):.2f} deg")
    print(f"moving fraction: tracked {np.nanmean(dyn_all):.3f}, inliers {np.nanmean(dyn_inl):.3f} (mean over frames)")
    bad = e_t > 0.1 * np.maximum(s_true, 0.05)
    print(f"frames with step error > 10 % of the step: {bad.sum()} of {len(rows)}; "
          f"their moving-inlier fraction {np.nanmean(dyn_inl[bad]):.3f}, the others {np.nanmean(dyn_inl[~bad]):.3f}")
    print(f"scale ratio |t_est|/|t_true| (moving): median {np.median(s_est[s_true > 0.05] / s_true[s_true > 0.05]):.3f}")
    order = np.argsort(-e_t)[:15]
    print("worst steps: k status n_feat n_inl moving(tracked) moving(inliers) |t_true| |t_est| err_m err_deg")
    for i in sorted(order):
        print(f"  {k[i]:4d} {st[i]:9s} {nf[i]:4d} {ni[i]:4d} {dyn_all[i]:.2f} {dyn_inl[i]:.2f} "
              f"{s_true[i]:.3f} {s_est[i]:.3f} {e_t[i]:.3f} {e_r[i]:.2f}")
    hi = dyn_inl > 0.5
    print(f"frames with > 50 % moving inliers: {hi.sum()}; mean step error there {np.mean(e_t[hi]) if hi.any() else 0:.3f} m, "
          f"elsewhere {np.mean(e_t[~hi]):.3f} m; sum of step errors there {np.sum(e_t[hi]):.1f} of {np.sum(e_t):.1f} m")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("--estimator", default="klt-pnp")
    ap.add_argument("--max-frames", type=int)
    ap.add_argument("--opt", action="append", default=[], help="KEY=VALUE (YAML value)")
    ap.add_argument("--oracle", action="store_true",
                    help="PnP estimators: drop the features on moving actors (true segmentation) before the PnP")
    a = ap.parse_args()
    options = {kv.split("=", 1)[0]: yaml.safe_load(kv.split("=", 1)[1]) for kv in a.opt}
    report(run(a.dataset, a.estimator, a.max_frames, options, a.oracle))


if __name__ == "__main__":
    main()
