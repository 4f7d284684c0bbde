"""Seed 002 Table 2/3 rows for one dataset: ``python docs/studies/vins_tables.py DATASET OUT FRAMES CONFIGS [key=value ...]``.

Runs each configuration (comma-separated registered names, e.g. ``vins,vins-ac-me,vins-oracle``) on the first
FRAMES frames with the estimator options ``key=value`` (e.g. ``init=truth``) and writes ``OUT/<name>.json``, the
row of :func:`vo.vins.tables.run_config` (first non-``init`` frame, RPE over 1 and 10 frames, drift, ATE, feature
statistics, stage timings); ``OUT/<name>.npz`` keeps poses, truth, statuses and covariances.
:func:`seed_medians` / :func:`format_seed_table` summarise several seeds (medians, per-seed improvement).
Bad input: one ``error:`` line, exit 2.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from rigs.errors import TestbedError
from rigs.typed_config import parse_value
from vo.dataset import open_dataset
from vo.errors import EstimatorError
from vo.vins.tables import improvement_pct, run_config


def _rpe(i: int):
    """The table's mean / std / max RPE (``i`` = 0, 1, 2) of a row; None without one."""
    return lambda r: r["rpe10"][i] if "rpe10" in r else None


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
    ap = argparse.ArgumentParser(prog="vins_tables.py", description=__doc__.splitlines()[0])
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
