"""Seed 002 Table 2/3 rows for one dataset: ``python -m vo.vins.tables DATASET OUT FRAMES CONFIGS [key=value ...]``.

Runs each configuration (comma-separated registered names, e.g. ``vins,vins-ac-me,vins-oracle``) on the first
FRAMES frames with the estimator options ``key=value`` (e.g. ``init=truth``) and writes ``OUT/<name>.json``:
the first non-``init`` frame; after it (poses aligned at that frame, as ``vo-testbed eval --align first``)
the RPE translation mean/std/max over 1 and 10 frames (evo's definition, ``vo.eval.rpe``), the end drift in
% of the path (seed 002 eq. 32), the ATE rmse; over all frames the N < 10 percentage, N percentiles and,
with a segmentation, the true dynamic percentage and the N < 10 rule's confusion; mean stage timings.
``OUT/<name>.npz`` keeps poses, truth, statuses and covariances.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import yaml

from vo.dataset import open_dataset
from vo.estimators.registry import make_estimator
from vo.eval.rpe import rpe
from vo.trajectory import Trajectory


def after_init(frames, gt_T_o_c0, t_ns) -> dict:
    """Metrics of the poses from the first non-``init`` frame on (empty when fewer than 20 remain)."""
    T = np.array([f.T_o_c0 for f in frames])
    first = next((i for i, f in enumerate(frames) if f.status != "init"), len(frames))
    out = {"init_frame": first}
    if first >= len(frames) - 20:
        return out
    Tg = gt_T_o_c0[first:len(T)]
    Te = Tg[0] @ np.linalg.inv(T[first]) @ T[first:]
    g, e = Trajectory(t_ns[first:len(T)], Tg, "o", "c0"), Trajectory(t_ns[first:len(T)], Te, "o", "c0")
    for d in (1, 10):
        tr = np.asarray(rpe(g, e, d, "frames").t_err_m)
        out[f"rpe{d}"] = [float(tr.mean()), float(tr.std()), float(tr.max())]
    out["path_m"] = float(g.path_length)
    out["drift_pct"] = float(np.linalg.norm(Te[-1, :3, 3] - Tg[-1, :3, 3]) / g.path_length * 100)
    out["ate_rmse"] = float(np.sqrt(np.mean(np.sum((Te[:, :3, 3] - Tg[:, :3, 3]) ** 2, 1))))
    return out


def feature_stats(diagnostics) -> dict:
    """N < 10 percentage and N percentiles; with true labels the dynamic percentage and the rule's confusion."""
    cnt = np.concatenate([d["counts"] for d in diagnostics])
    out = {"n_lt_10_pct": float(np.mean(cnt < 10) * 100),
           "N_pct": {p: float(np.percentile(cnt, p)) for p in (10, 50, 90, 99)}}
    if "n_dynamic" in diagnostics[0]:
        nd, ns = (sum(d[k] for d in diagnostics) for k in ("n_dynamic", "n_static"))
        dyn = np.concatenate([d["dynamic"] for d in diagnostics])
        out.update(true_dynamic_pct=100 * nd / max(nd + ns, 1),
                   static_as_outlier_pct=100 * sum(d["static_as_outlier"] for d in diagnostics) / max(ns, 1),
                   dynamic_as_inlier_pct=100 * sum(d["dynamic_as_inlier"] for d in diagnostics) / max(nd, 1),
                   N_median_dynamic=float(np.median(cnt[dyn])) if dyn.any() else None,
                   N_median_static=float(np.median(cnt[~dyn])))
    return out


def run(dataset_path, out_dir, n_frames: int, configs, options: dict) -> list:
    ds = open_dataset(dataset_path)
    gt = ds.groundtruth_cam0()
    gt_T = np.linalg.inv(gt.T[0]) @ gt.T
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in configs:
        est = make_estimator(name, ds.rig, **options)
        est.set_imu(ds.imu)
        est.set_dataset(ds)
        frames = [est.process(f) for f in ds.frames(0, min(n_frames, len(ds)))]
        row = {"name": name, "n": len(frames), **after_init(frames, gt_T, np.asarray(gt.t_ns))}
        row.update(feature_stats(est.diagnostics))
        first = row["init_frame"]
        row["timings_ms"] = {k: float(np.mean([f.timings_ms.get(k, 0.0) for f in frames[first:]]))
                             for k in frames[-1].timings_ms}
        (out_dir / f"{name}.json").write_text(json.dumps(row, indent=1))
        np.savez(out_dir / f"{name}.npz", T=np.array([f.T_o_c0 for f in frames]), G=gt_T[:len(frames)],
                 status=np.array([f.status for f in frames]),
                 cov=np.array([f.cov if f.cov is not None else np.full((6, 6), np.nan) for f in frames]))
        rows.append(row)
    return rows


if __name__ == "__main__":
    path, out, n, names = sys.argv[1:5]
    opts = {k: yaml.safe_load(v) for k, v in (a.split("=", 1) for a in sys.argv[5:])}
    for r in run(path, out, int(n), names.split(","), opts):
        print(json.dumps(r))
