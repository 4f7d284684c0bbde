"""``vo-testbed run``: run an estimator on a dataset folder and save trajectory, frame log and summary."""
from __future__ import annotations

import click

from sim.app.cli.options import echo_json, opt_option, parse_opts


@click.command("run")
@click.option("--dataset", "dataset_dir", required=True, type=click.Path(exists=True, file_okay=False),
              help="Dataset folder (ours EuRoC/KITTI, real EuRoC mav0 parent, KITTI sequences/NN).")
@click.option("--estimator", required=True,
              help="Registered name (see `vo-testbed list`), 'package.module:Class', or "
                   "'cmd:prog --data {dataset} --traj {out}' (the program sees the sensor data only).")
@click.option("--frontend", type=click.Choice(["klt", "orb", "sift"]), default=None,
              help="Front-end for estimators that take one (orb-pnp: orb|sift; rop: klt|orb|sift).")
@click.option("--max-frames", type=click.IntRange(min=1), default=None, help="Process at most N frames.")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False), help="Output folder.")
@opt_option
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of OpenCV's random generator (RANSAC).")
@click.option("--no-progress", is_flag=True,
              help="No progress report (by default a bar on a terminal, a line per 10 % of the frames otherwise).")
def run(dataset_dir, estimator, frontend, max_frames, out_dir, estimator_opts, as_json, seed, no_progress):
    """Run ESTIMATOR on DATASET, write OUT/{trajectory_tum.txt, trajectory_kitti.txt (+ times.txt), frames.csv,
    summary.json} and, when the dataset has ground truth, OUT/metrics.json and plots.

    Frames are counted by status: ok (a measured pose), coasting (predicted without a measurement), init and
    lost (placeholders, not evaluated); frames.csv keeps each frame's class in its `pose` column, which
    `vo-testbed eval` reads."""
    from vo.eval.evaluate import status_text
    from vo.pipeline import run_dataset
    result, evaluated = run_dataset(dataset_dir, estimator, out_dir, parse_opts(estimator_opts, frontend),
                                    progress=not no_progress, max_frames=max_frames, seed=seed)
    summary = dict(result.summary(), out=str(out_dir))
    if evaluated is not None:
        summary["metrics"] = evaluated.evaluation.to_dict()
    if as_json:
        echo_json(summary)
        return
    click.echo(f"{summary['estimator']}: {summary['n_frames']} frames, {summary['n_lost']} lost, "
               f"path {summary['path_length_m']:.2f} m, wall {summary['wall_time_s']:.1f} s")
    if result.timings_ms:
        click.echo("mean ms/frame: " + ", ".join(f"{k} {v:.1f}" for k, v in result.timings_ms.items()))
    counts = summary["frames_by_status"]
    click.echo(f"frames by status: {status_text(counts)}")
    if evaluated is not None:
        click.echo(evaluated.evaluation.table())
    elif counts["ok"] + counts["coasting"] < 2:
        click.echo(f"not evaluated: {counts['ok'] + counts['coasting']} estimated pose(s); "
                   + ("the estimator never initialised" if counts["ok"] + counts["coasting"] == 0 else "2 are needed"))
    click.echo(f"written to {out_dir}")
