"""Seed 002 Table 2/3 rows for one dataset: ``python -m vo.vins.tables DATASET OUT FRAMES CONFIGS [key=value ...]``.

Runs each configuration (comma-separated registered names, e.g. ``vins,vins-ac-me,vins-oracle``) on the first
FRAMES frames with the estimator options ``key=value`` (e.g. ``init=truth``) and writes ``OUT/<name>.json``:
the first non-``init`` frame; after it (poses aligned at that frame, as ``vo-testbed eval --align first``)
the RPE translation mean/std/max over 1 and 10 frames (evo's definition, ``vo.eval.rpe``), the end drift in
% of the path (seed 002 eq. 32), the ATE rmse; over all frames the N < 10 percentage, N percentiles and,
with a segmentation, the true dynamic percentage and the N < 10 rule's confusion; mean stage timings.
``OUT/<name>.npz`` keeps poses, truth, statuses and covariances.

:func:`table23` / :func:`format_table23` lay rows out as seed 002's Tables 2 and 3 (metrics down, configurations
across), with the rows the paper cannot give (true dynamic share, the N < 10 rule's two confusion rates);
:func:`seed_medians` / :func:`format_seed_table` summarise several seeds (medians, per-seed improvement).
"""
from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigs.typed_config import parse_value
from vo.dataset import open_dataset
from vo.errors import EstimatorError
from vo.estimators.registry import make_estimator
from vo.eval.rpe import rpe
from vo.trajectory import Trajectory

# seed 002's four configurations (Tables 2/3 columns), then the perfect-detection row
TABLE_CONFIGS = ("vins", "vins-ac-gf", "vins-ac", "vins-ac-me", "vins-oracle")
HEADERS = {"vins": "VINS", "vins-ac-gf": "VINS-AC(g_f)", "vins-ac": "VINS-AC(g_f,N)", "vins-ac-me": "VINS-AC-ME",
           "vins-oracle": "oracle", "vins-huber": "Huber k=1"}
RPE_DELTA = 10           # frames (1 s at 10 Hz): the table's RPE pairs
MIN_AFTER_INIT = 20      # fewer post-init frames than this: no metrics


def _aligned(frames, gt_T_o_c0):
    """(first non-``init`` index, truth, estimate aligned at that frame) or None when too few frames remain."""
    T = np.array([f.T_o_c0 for f in frames])
    first = next((i for i, f in enumerate(frames) if f.status != "init"), len(frames))
    if first >= len(frames) - MIN_AFTER_INIT:
        return first, None, None
    Tg = gt_T_o_c0[first:len(T)]
    return first, Tg, Tg[0] @ np.linalg.inv(T[first]) @ T[first:]


def after_init(frames, gt_T_o_c0, t_ns) -> dict:
    """Metrics of the poses from the first non-``init`` frame on (empty when fewer than 20 remain)."""
    first, Tg, Te = _aligned(frames, gt_T_o_c0)
    out = {"init_frame": first}
    if Tg is None:
        return out
    t = t_ns[first:len(frames)]
    g, e = Trajectory(t, Tg, "o", "c0"), Trajectory(t, Te, "o", "c0")
    for d in (1, RPE_DELTA):
        tr = np.asarray(rpe(g, e, d, "frames").t_err_m)
        out[f"rpe{d}"] = [float(tr.mean()), float(tr.std()), float(tr.max())]
    out["path_m"] = float(g.path_length)
    out["drift_pct"] = float(np.linalg.norm(Te[-1, :3, 3] - Tg[-1, :3, 3]) / g.path_length * 100)
    out["ate_rmse"] = float(np.sqrt(np.mean(np.sum((Te[:, :3, 3] - Tg[:, :3, 3]) ** 2, 1))))
    return out


def rpe_series(frames, gt_T_o_c0, t_ns, delta: int = RPE_DELTA) -> tuple:
    """The table's RPE pairs over time: (time in s of each pair's end frame, translation error m); empty
    arrays when the run did not initialise. Their mean/std/max are ``after_init``'s ``rpe<delta>``."""
    first, Tg, Te = _aligned(frames, gt_T_o_c0)
    if Tg is None:
        return np.zeros(0), np.zeros(0)
    t = np.asarray(t_ns[first:len(frames)], np.int64)
    res = rpe(Trajectory(t, Tg, "o", "c0"), Trajectory(t, Te, "o", "c0"), delta, "frames")
    return (t[res.pairs[:, 1]] - int(t_ns[0])) * 1e-9, np.asarray(res.t_err_m)


def feature_stats(diagnostics) -> dict:
    """N < 10 percentage and N percentiles; with true labels the dynamic percentage and the rule's confusion
    (a rate over no features, e.g. dynamic ones on a static scene, is None)."""
    cnt = np.concatenate([d["counts"] for d in diagnostics])
    out = {"n_lt_10_pct": float(np.mean(cnt < 10) * 100),
           "N_pct": {p: float(np.percentile(cnt, p)) for p in (10, 50, 90, 99)}}
    if "n_dynamic" in diagnostics[0]:
        nd, ns = (sum(d[k] for d in diagnostics) for k in ("n_dynamic", "n_static"))
        dyn = np.concatenate([d["dynamic"] for d in diagnostics])
        out.update(true_dynamic_pct=100 * nd / max(nd + ns, 1),
                   static_as_outlier_pct=100 * sum(d["static_as_outlier"] for d in diagnostics) / ns if ns else None,
                   dynamic_as_inlier_pct=100 * sum(d["dynamic_as_inlier"] for d in diagnostics) / nd if nd else None,
                   N_median_dynamic=float(np.median(cnt[dyn])) if dyn.any() else None,
                   N_median_static=float(np.median(cnt[~dyn])))
    return out


@dataclass
class ConfigRun:
    """One configuration on one dataset: its table row, per-frame results and the estimator's diagnostics."""

    name: str
    row: dict
    frames: list
    diagnostics: list


def run_config(ds, name: str, n_frames: int, options: dict, progress: bool = False) -> ConfigRun:
    """Run ``name`` on the first ``n_frames`` frames of the opened dataset ``ds`` and compute its row."""
    gt = ds.groundtruth_cam0()
    gt_T = np.linalg.inv(gt.T[0]) @ gt.T
    est = make_estimator(name, ds.rig, **options)
    est.set_imu(ds.imu)
    est.set_dataset(ds)
    n = min(n_frames, len(ds))
    frames = [est.process(f) for f in _progress(ds.frames(0, n), n, progress, name)]
    row = {"name": name, "n": len(frames), **after_init(frames, gt_T, np.asarray(gt.t_ns))}
    row.update(feature_stats(est.diagnostics))
    post = frames[row["init_frame"]:]          # mean stage timings after initialisation (none: empty)
    row["timings_ms"] = {k: float(np.mean([f.timings_ms.get(k, 0.0) for f in post])) for k in
                         (post[-1].timings_ms if post else ())}
    return ConfigRun(name, row, frames, est.diagnostics)


def _progress(it, total: int, enabled: bool, desc: str):
    if not enabled or not sys.stderr.isatty():
        return it
    from tqdm import tqdm
    return tqdm(it, total=total, desc=desc, unit="frame")


def run(dataset_path, out_dir, n_frames: int, configs, options: dict) -> list:
    ds = open_dataset(dataset_path)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    gt = ds.groundtruth_cam0()
    gt_T = np.linalg.inv(gt.T[0]) @ gt.T
    rows = []
    for name in configs:
        r = run_config(ds, name, n_frames, options)
        (out_dir / f"{name}.json").write_text(json.dumps(r.row, indent=1))
        np.savez(out_dir / f"{name}.npz", T=np.array([f.T_o_c0 for f in r.frames]), G=gt_T[:len(r.frames)],
                 status=np.array([f.status for f in r.frames]),
                 cov=np.array([f.cov if f.cov is not None else np.full((6, 6), np.nan) for f in r.frames]))
        rows.append(r.row)
    return rows


def _rpe(i: int):
    return lambda r: r["rpe10"][i] if "rpe10" in r else None


# (label, value of a row, format): seed 002's Table 2/3 rows, then the rows only a simulation can give
TABLE_ROWS = (
    (f"Mean error (RPE/{RPE_DELTA} fr, m)", _rpe(0), "{:.3f}"),
    ("Std (m)", _rpe(1), "{:.3f}"),
    ("Max error (m)", _rpe(2), "{:.3f}"),
    ("% drift per meter (eq. 32)", lambda r: r.get("drift_pct"), "{:.2f}"),
    ("Improvement over VINS (%)", None, "{:.1f}"),
    ("% outliers (N < 10)", lambda r: r.get("n_lt_10_pct"), "{:.1f}"),
    ("% dynamic (true)", lambda r: r.get("true_dynamic_pct"), "{:.1f}"),
    ("% static called outlier", lambda r: r.get("static_as_outlier_pct"), "{:.1f}"),
    ("% dynamic called inlier", lambda r: r.get("dynamic_as_inlier_pct"), "{:.1f}"),
    ("first post-init frame", lambda r: r.get("init_frame"), "{:d}"),
)


def improvement_pct(rows, baseline: str = "vins") -> dict:
    """name -> 100 (mean RPE of ``baseline`` - its mean RPE) / mean RPE of ``baseline`` (the paper's
    "Improvement"); None for the baseline itself and where either run has no RPE."""
    base = next((r for r in rows if r["name"] == baseline), None)
    b = _rpe(0)(base) if base is not None else None
    return {r["name"]: (100 * (b - _rpe(0)(r)) / b if b and r is not base and _rpe(0)(r) is not None else None)
            for r in rows}


def table23(rows, baseline: str = "vins") -> list:
    """[(label, [value per row])] in :data:`TABLE_ROWS` order (None where a run gives no value)."""
    imp = improvement_pct(rows, baseline)
    return [(label, [imp[r["name"]] if fn is None else fn(r) for r in rows]) for label, fn, _ in TABLE_ROWS]


def format_table23(rows, baseline: str = "vins") -> str:
    """Markdown table: metrics down, configurations across (seed 002 Tables 2/3); "-": no value."""
    head = ["", *(HEADERS.get(r["name"], r["name"]) for r in rows)]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for (label, values), (_, _, fmt) in zip(table23(rows, baseline), TABLE_ROWS):
        lines.append("| " + " | ".join([label, *("-" if v is None else fmt.format(v) for v in values)]) + " |")
    return "\n".join(lines)


def seed_medians(runs) -> list:
    """Rows over seeds: ``runs`` {seed: [row per configuration]} -> one row per configuration (first seed's
    order) with ``seeds`` (how many), ``seeds_initialised``, the medians over the initialised seeds of the RPE
    mean/std/max, drift and label columns, and ``improvement_pct``: the median over seeds of the per-seed
    improvement of the mean RPE over ``vins`` (seeds where both initialised)."""
    names = [r["name"] for r in next(iter(runs.values()))]
    imps = {s: improvement_pct(rows) for s, rows in runs.items()}
    out = []
    for name in names:
        per = {s: r for s, rows in runs.items() for r in rows if r["name"] == name}
        ok = [r for r in per.values() if "rpe10" in r]
        row = {"name": name, "seeds": len(per), "seeds_initialised": len(ok)}
        med = lambda f: (float(np.median(v)) if (v := [x for x in map(f, ok) if x is not None]) else None)
        if ok:
            row["rpe10"] = [med(_rpe(i)) for i in range(3)]
        for key in ("drift_pct", "n_lt_10_pct", "true_dynamic_pct", "static_as_outlier_pct",
                    "dynamic_as_inlier_pct", "init_frame"):
            row[key] = med(lambda r, k=key: r.get(k))
        imp = [v for s in per if (v := imps[s].get(name)) is not None]
        row["improvement_pct"] = float(np.median(imp)) if imp else None
        out.append(row)
    return out


def format_seed_table(runs) -> str:
    """Markdown: one line per configuration with the :func:`seed_medians` columns, then per-seed RPE / drift."""
    cols = ("seeds initialised", "RPE mean m", "RPE std m", "RPE max m", "drift %", "RPE vs vins",
            "N<10 %", "true dynamic %", "static N<10 %", "dynamic N>=10 %")
    f = lambda v, fmt: "-" if v is None else fmt.format(v)
    lines = ["| config | " + " | ".join(cols) + " |", "|---" * (len(cols) + 1) + "|"]
    for r in seed_medians(runs):
        rp = r.get("rpe10", [None] * 3)
        lines.append("| " + " | ".join([r["name"], f"{r['seeds_initialised']} of {r['seeds']}",
                                         *(f(v, "{:.3f}") for v in rp), f(r["drift_pct"], "{:.2f}"),
                                         f(r["improvement_pct"], "{:+.1f} %"),
                                         *(f(r[k], "{:.1f}") for k in ("n_lt_10_pct", "true_dynamic_pct",
                                                                       "static_as_outlier_pct",
                                                                       "dynamic_as_inlier_pct"))]) + " |")
    lines.append("")
    for name in (r["name"] for r in next(iter(runs.values()))):
        per = [f"{s}: " + (f"{r['rpe10'][0]:.2f} m / {r['drift_pct']:.1f} %" if "rpe10" in r else "no initialisation")
               for s, rows in runs.items() for r in rows if r["name"] == name]
        lines.append(f"* {name}, RPE mean / drift per seed: " + "; ".join(per) + ".")
    return "\n".join(lines)


def main(argv=None) -> int:
    """CLI (module docstring): one-line error and exit 2 on bad arguments or a bad dataset."""
    import argparse
    from rigs.errors import TestbedError
    ap = argparse.ArgumentParser(prog="python -m vo.vins.tables", description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("out")
    ap.add_argument("frames", type=int)
    ap.add_argument("configs", help="comma-separated estimator names, e.g. vins,vins-ac-me")
    ap.add_argument("options", nargs="*", metavar="key=value")
    a = ap.parse_args(argv)
    bad = [o for o in a.options if "=" not in o]
    if bad:
        ap.error(f"option {bad[0]!r}: expected key=value")
    try:
        opts = {k: parse_value(v, k, EstimatorError) for k, v in (o.split("=", 1) for o in a.options)}
        for r in run(a.dataset, a.out, a.frames, a.configs.split(","), opts):
            print(json.dumps(r))
    except TestbedError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
