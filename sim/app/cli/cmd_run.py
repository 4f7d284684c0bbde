"""``vo-testbed run``: run an estimator on a dataset folder and save trajectory, frame log and summary."""
from __future__ import annotations

import json

import click

from sim.app.cli.options import opt_option, parse_opts


@click.command("run")
@click.option("--dataset", "dataset_dir", required=True, type=click.Path(exists=True, file_okay=False),
              help="Dataset folder (ours EuRoC/KITTI, real EuRoC mav0 parent, KITTI sequences/NN).")
@click.option("--estimator", required=True,
              help="Registered name (rop, klt-pnp, orb-pnp), 'package.module:Class', or 'cmd:prog --data {dataset} --traj {out}'.")
@click.option("--frontend", type=click.Choice(["klt", "orb", "sift"]), default=None,
              help="Front-end for estimators that take one (orb-pnp: orb|sift; rop: klt|orb|sift).")
@click.option("--max-frames", type=click.IntRange(min=1), default=None, help="Process at most N frames.")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False), help="Output folder.")
@opt_option
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@click.option("--no-progress", is_flag=True, help="Disable the progress bar.")
def run(dataset_dir, estimator, frontend, max_frames, out_dir, estimator_opts, as_json, no_progress):
    """Run ESTIMATOR on DATASET, write OUT/{trajectory_tum.txt, trajectory_kitti.txt, frames.csv, summary.json}."""
    from vo.estimators.registry import is_external
    from vo.estimators.runner import run_estimator

    options = parse_opts(estimator_opts, frontend)
    if is_external(estimator):
        dataset = dataset_dir
    else:
        from vo.dataset import open_dataset
        dataset = open_dataset(dataset_dir)
    result = run_estimator(estimator, dataset, options, progress=not no_progress, max_frames=max_frames)
    result.save(out_dir)
    summary = result.summary()
    summary["out"] = str(out_dir)
    evaluated = _evaluate(dataset_dir, result, estimator, out_dir)
    if evaluated is not None:
        summary["metrics"] = evaluated.evaluation.to_dict()
    if as_json:
        click.echo(json.dumps(summary, indent=2, default=str))
        return
    click.echo(f"{summary['estimator']}: {summary['n_frames']} frames, {summary['n_lost']} lost, "
               f"path {summary['path_length_m']:.2f} m, wall {summary['wall_time_s']:.1f} s")
    if result.timings_ms:
        click.echo("mean ms/frame: " + ", ".join(f"{k} {v:.1f}" for k, v in result.timings_ms.items()))
    if evaluated is not None:
        ev = evaluated.evaluation
        click.echo(ev.table())
    click.echo(f"written to {out_dir}")


def _evaluate(dataset_dir, result, estimator, out_dir):
    """Evaluate against the dataset's ground truth when it has one (None otherwise)."""
    from vo.dataset import open_dataset
    from vo.errors import DatasetError
    from vo.pipeline import evaluate_run
    try:
        ds = open_dataset(dataset_dir)
    except DatasetError:      # an external command may run on a folder our reader does not know
        return None
    if getattr(ds, "groundtruth", None) is None:
        return None
    return evaluate_run(ds, result, estimator, out_dir=out_dir)
