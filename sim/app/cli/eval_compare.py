"""``vo-testbed eval`` with several ``--est`` files (one table, one plot) and ``--save-results`` (evo's
result zip). Only parses and prints; the work is :mod:`vo.eval` (``compare``, ``evo_results``, ``plots``)."""
from __future__ import annotations

import json
from pathlib import Path

import click


def results_paths(save_path: str, names: list) -> list:
    """One evo result zip per estimate: ``save_path`` itself for one, ``<stem>.<name>.zip`` beside it for several."""
    p = Path(save_path)
    if len(names) == 1:
        return [p]
    return [p.with_name(f"{p.stem}.{Path(n).stem}.zip") for n in names]


def save_results(results: dict, save_path: str, gt_path: str, est_paths: list) -> list:
    """Write evo's result zip of each estimate (name -> EvalResult); returns the paths."""
    from vo.eval.evo_results import save_evo_result
    return [save_evo_result(r, out, ref_name=str(gt_path), est_name=str(est))
            for r, out, est in zip(results.values(), results_paths(save_path, list(results)), est_paths)]


def compare_estimates(gt_path, est_paths, fmt, align, gcps_path, times_path, t_offset_s, frames_path, max_diff_ms,
                      rpe_delta_m, plot_dir, as_json, save_path, finite_or_none) -> None:
    """Evaluate every estimate against the same ground truth (each with its own times.txt / frames.csv
    beside it, the same --t-offset); print one table (or JSON), write one comparison plot, and evo result
    files when ``save_path`` is given."""
    from vo.eval import evaluate
    from vo.eval.compare import compare_table, compare_to_dict, estimate_names
    from vo.pipeline import load_estimate, load_gcps, load_groundtruth, prepare_out_dir
    if times_path or frames_path:
        raise click.UsageError("--times and --frames name one estimate's files; with several --est each "
                               "estimate's own times.txt and frames.csv beside it are read")
    gt, gcps, note = load_groundtruth(gt_path, fmt)
    gcps = load_gcps(gcps_path) if gcps_path else (gcps or None)
    out = prepare_out_dir(plot_dir) if plot_dir else None
    results, notes = {}, [note] if note else []
    for name, est_path in zip(estimate_names(est_paths), est_paths):
        est, classes, est_notes = load_estimate(est_path, fmt, None, None)
        notes += est_notes
        results[name] = evaluate(gt, est, gcps=gcps, align=align, max_diff_ns=int(round(max_diff_ms * 1e6)),
                                 rpe_delta_m=rpe_delta_m, pose_classes=classes,
                                 t_offset_ns=int(round(t_offset_s * 1e9)), offset_check=True)
    plots = []
    if out:
        from vo.eval.plots import plot_comparison     # matplotlib only when plotting
        plots = [plot_comparison(results, gt, out / "comparison.png")]
    saved = save_results(results, save_path, gt_path, est_paths) if save_path else []
    for line in notes:
        click.echo(line, err=True)
    if as_json:
        d = finite_or_none(compare_to_dict(results, align))
        d["plots"], d["results"] = [str(p) for p in plots], [str(p) for p in saved]
        click.echo(json.dumps(d, indent=2, sort_keys=True, allow_nan=False))
        return
    click.echo(compare_table(results, align))
    for p in plots:
        click.echo(f"plot: {p}")
    for p in saved:
        click.echo(f"results (evo): {p}")
