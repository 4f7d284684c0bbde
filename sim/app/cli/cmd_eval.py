"""``vo-testbed eval``: compare an estimated trajectory with ground truth (ATE, RPE, drift, KITTI, GCPs).

Only parses arguments and calls :mod:`vo.eval`; never imports mujoco.
"""
from __future__ import annotations

import json
import math

import click

FORMATS = ("auto", "tum", "kitti", "euroc")
ALIGNS = ("first", "se3", "sim3", "posyaw", "none")


def _positive(ctx, param, value):
    if value is not None and not (math.isfinite(value) and value > 0):      # 0, negative, NaN, inf
        raise click.BadParameter(f"must be a finite number > 0, got {value}")
    return value


def _finite(ctx, param, value):
    if not math.isfinite(value):
        raise click.BadParameter(f"must be a finite number, got {value}")
    return value


def _finite_or_none(obj):
    """Replace NaN/inf floats (e.g. no KITTI segment fits) by None so the output is strict JSON."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite_or_none(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite_or_none(v) for v in obj]
    return obj


@click.command("eval")
@click.option("--gt", "gt_path", required=True, type=click.Path(),
              help="Ground-truth trajectory file, or a dataset folder (ours, real EuRoC or KITTI): then the left "
                   "camera's trajectory T_w_c0 at the frame times (EuRoC truth is the IMU/body frame; the "
                   "extrinsics are applied), and its GCPs.")
@click.option("--est", "est_path", required=True, type=click.Path(dir_okay=False), help="Estimated trajectory file.")
@click.option("--format", "fmt", type=click.Choice(FORMATS), default="auto", show_default=True,
              help="Format of both files (auto: detect per file).")
@click.option("--align", "align", type=click.Choice(ALIGNS), default="first", show_default=True,
              help="Alignment of the estimate onto ground truth.")
@click.option("--gcps", "gcps_path", type=click.Path(dir_okay=False), default=None,
              help="GCP csv (#name,t_ns,ground_x,ground_y,ground_z,c0_x,c0_y,c0_z) for the seed 000 table.")
@click.option("--times", "times_path", type=click.Path(dir_okay=False), default=None,
              help="Timestamps (seconds, one per pose) of a KITTI estimate; default: the times.txt beside it "
                   "(no rate is ever assumed).")
@click.option("--t-offset", "t_offset_s", type=float, default=0.0, show_default=True, callback=_finite,
              help="Seconds added to the estimate's timestamps before association.")
@click.option("--frames", "frames_path", type=click.Path(dir_okay=False), default=None,
              help="The run's frame log (frames.csv) giving each pose's status; default: frames.csv beside "
                   "--est. Placeholder poses (init, lost) are then not covered and not scored.")
@click.option("--max-diff-ms", type=float, default=10.0, show_default=True, help="Timestamp association tolerance.")
@click.option("--rpe-delta-m", type=float, default=None, callback=_positive,
              help="RPE distance step, m > 0 (default 10% of the gt path).")
@click.option("--plot", "plot_dir", type=click.Path(file_okay=False), default=None, help="Write PNG plots here.")
@click.option("--json", "as_json", is_flag=True, help="Print machine-readable JSON instead of a table.")
def eval_cmd(gt_path, est_path, fmt, align, gcps_path, times_path, t_offset_s, frames_path, max_diff_ms,
             rpe_delta_m, plot_dir, as_json):
    """Evaluate an estimated trajectory against ground truth (frames by status, coverage, ATE, RPE, drift,
    KITTI, GCPs). Says on stderr what it compared (files, timestamps, frame log).

    Warns when the rotation error after alignment says the two track different frames, when fewer than half
    the estimated poses associate, and when a constant time offset explains the estimate far better (with
    the --t-offset to use)."""
    from vo.eval import evaluate
    from vo.pipeline import load_estimate, load_gcps, load_groundtruth, prepare_out_dir
    gt, gcps, note = load_groundtruth(gt_path, fmt)
    est, classes, est_notes = load_estimate(est_path, fmt, times_path, frames_path)
    gcps = load_gcps(gcps_path) if gcps_path else (gcps or None)
    out = prepare_out_dir(plot_dir) if plot_dir else None
    result = evaluate(gt, est, gcps=gcps, align=align, max_diff_ns=int(round(max_diff_ms * 1e6)),
                      rpe_delta_m=rpe_delta_m, pose_classes=classes, t_offset_ns=int(round(t_offset_s * 1e9)),
                      offset_check=True)
    plots = []
    if out:
        from vo.eval.plots import plot_evaluation     # matplotlib only when plotting
        plots = plot_evaluation(result, gcps, out)
    for line in ([note] if note else []) + est_notes + [f"warning: {w}" for w in result.warnings if as_json]:
        click.echo(line, err=True)       # the table prints its warnings itself
    if as_json:
        d = _finite_or_none(result.to_dict())
        d["plots"] = [str(p) for p in plots]
        click.echo(json.dumps(d, indent=2, sort_keys=True, allow_nan=False))
        return
    click.echo(result.table())
    for p in plots:
        click.echo(f"plot: {p}")
