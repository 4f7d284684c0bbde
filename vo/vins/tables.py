"""Seed 002 Table 2/3 rows for one dataset (the ``demo`` command; the study driver is
docs/studies/vins_tables.py).

:func:`run_config` runs one configuration (a registered name, e.g. ``vins-ac-me``) on the first frames of a
dataset and computes its row: the first non-``init`` frame; after it (poses aligned at that frame, as
``vo-testbed eval --align first``) the RPE translation mean/std/max over 1 and 10 frames (evo's definition, ``vo.eval.rpe``), the end drift in
% of the path (seed 002 eq. 32), the ATE rmse; over all frames the N < 10 percentage, N percentiles and,
with a segmentation, the true dynamic percentage and the N < 10 rule's confusion; mean stage timings.

:func:`table23` / :func:`format_table23` lay rows out as seed 002's Tables 2 and 3 (metrics down, configurations
across), with the rows the paper cannot give (true dynamic share, the N < 10 rule's two confusion rates);
:func:`seed_medians` / :func:`format_seed_table` summarise several seeds (medians, per-seed improvement).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vo.estimators.runner import run_estimator
from vo.eval.rpe import rpe
from rigs.trajectory import Trajectory

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
    """Run ``name`` on the first ``n_frames`` frames of the opened dataset ``ds`` (the product runner,
    :func:`vo.estimators.runner.run_estimator`, with the whole dataset for the labelled diagnostics) and
    compute its row."""
    gt = ds.groundtruth_cam0()
    gt_T = np.linalg.inv(gt.T[0]) @ gt.T
    run = run_estimator(name, ds, options, progress=progress, max_frames=n_frames, with_truth=True)
    frames, diagnostics = run.frames, run.diagnostics
    row = {"name": name, "n": len(frames), **after_init(frames, gt_T, np.asarray(gt.t_ns))}
    row.update(feature_stats(diagnostics))
    post = frames[row["init_frame"]:]          # mean stage timings after initialisation (none: empty)
    row["timings_ms"] = {k: float(np.mean([f.timings_ms.get(k, 0.0) for f in post])) for k in
                         (post[-1].timings_ms if post else ())}
    return ConfigRun(name, row, frames, diagnostics)


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
