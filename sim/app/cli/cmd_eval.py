"""``vo-testbed eval``: compare an estimated trajectory with ground truth (ATE, RPE, drift, KITTI, GCPs).

Only parses arguments and calls :mod:`vo.eval`; never imports mujoco.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import click

FORMATS = ("auto", "tum", "kitti", "euroc")
ALIGNS = ("first", "se3", "sim3", "posyaw", "none")


def _read_gcps(path):
    from vo.dataset.base import read_gcps_csv
    from vo.errors import DatasetError
    if not Path(path).is_file():
        raise DatasetError(f"{path}: GCP file not found")
    gcps = read_gcps_csv(Path(path))
    if not gcps:
        raise DatasetError(f"{path}: no GCP rows (expected #name,t_ns,ground_x,ground_y,ground_z,c0_x,c0_y,c0_z)")
    return gcps


def _finite_or_none(obj):
    """Replace NaN/inf floats (e.g. no KITTI segment fits) by None so the output is strict JSON."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite_or_none(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite_or_none(v) for v in obj]
    return obj


def _write_plots(result, gcps, out_dir: Path) -> list:
    from vo.eval.plots import plot_error_vs_distance, plot_rpe, plot_topdown
    est = {"estimate": result.aligned_est}
    return [plot_topdown(est, result.gt_matched, gcps, out_dir / "topdown.png"),
            plot_error_vs_distance(result.gt_matched, est, out_dir / "error_vs_distance.png"),
            plot_rpe({"estimate": result.rpe_frame}, out_dir / "rpe.png")]


@click.command("eval")
@click.option("--gt", "gt_path", required=True, type=click.Path(dir_okay=False), help="Ground-truth trajectory file.")
@click.option("--est", "est_path", required=True, type=click.Path(dir_okay=False), help="Estimated trajectory file.")
@click.option("--format", "fmt", type=click.Choice(FORMATS), default="auto", show_default=True,
              help="Format of both files (auto: detect per file).")
@click.option("--align", "align", type=click.Choice(ALIGNS), default="first", show_default=True,
              help="Alignment of the estimate onto ground truth.")
@click.option("--gcps", "gcps_path", type=click.Path(dir_okay=False), default=None,
              help="GCP csv (#name,t_ns,ground_x,ground_y,ground_z,c0_x,c0_y,c0_z) for the seed 000 table.")
@click.option("--max-diff-ms", type=float, default=10.0, show_default=True, help="Timestamp association tolerance.")
@click.option("--rpe-delta-m", type=float, default=None, help="RPE distance step (default 10% of the gt path).")
@click.option("--plot", "plot_dir", type=click.Path(file_okay=False), default=None, help="Write PNG plots here.")
@click.option("--json", "as_json", is_flag=True, help="Print machine-readable JSON instead of a table.")
def eval_cmd(gt_path, est_path, fmt, align, gcps_path, max_diff_ms, rpe_delta_m, plot_dir, as_json):
    """Evaluate an estimated trajectory against ground truth."""
    from vo.eval import evaluate
    from vo.trajfile import read_trajectory
    gt = read_trajectory(gt_path, fmt)
    est = read_trajectory(est_path, fmt)
    gcps = _read_gcps(gcps_path) if gcps_path else None
    result = evaluate(gt, est, gcps=gcps, align=align, max_diff_ns=int(round(max_diff_ms * 1e6)),
                      rpe_delta_m=rpe_delta_m)
    plots = _write_plots(result, gcps, Path(plot_dir)) if plot_dir else []
    if as_json:
        d = _finite_or_none(result.to_dict())
        d["plots"] = [str(p) for p in plots]
        click.echo(json.dumps(d, indent=2, sort_keys=True, allow_nan=False))
        return
    click.echo(result.table())
    for p in plots:
        click.echo(f"plot: {p}")
