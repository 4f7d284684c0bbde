"""``vo-testbed export``: write a dataset folder as a ROS 1 bag or a ROS 2 bag (no ROS install needed)."""
from __future__ import annotations

import click

from sim.app.cli.options import echo_json, json_option


@click.command("export")
@click.option("--dataset", "dataset_dir", required=True, type=click.Path(exists=True, file_okay=False),
              help="Dataset folder (ours EuRoC/KITTI or a --format both root, real EuRoC, KITTI sequences/NN).")
@click.option("--to", "kind", required=True, type=click.Choice(["rosbag1", "rosbag2"]),
              help="rosbag1: one .bag file (format 2.0); rosbag2: a bag folder.")
@click.option("--storage", type=click.Choice(["sqlite3", "mcap"]), default="mcap", show_default=True,
              help="ROS 2 storage plugin (rosbag2 only; MCAP is ROS 2's default since Iron).")
@click.option("--out", "out_path", required=True, type=click.Path(),
              help="Bag to create (rosbag1: a file such as run.bag; rosbag2: a new folder). Must not exist.")
@click.option("--truth/--no-truth", default=True, show_default=True,
              help="--no-truth: sensor topics only (no /groundtruth/*), to hand to a program under test.")
@json_option
@click.pass_context
def export(ctx, dataset_dir, kind, storage, out_path, truth, as_json):
    """Export DATASET as a bag: /cam0/image_raw, /cam1/image_raw, /camK/camera_info, /imu0, /tf_static,
    /groundtruth/pose, /groundtruth/cam0 (and /wheels); timestamps are the dataset's own."""
    from click.core import ParameterSource
    from sim.app.rosbag_export import export_rosbag
    if kind == "rosbag1" and ctx.get_parameter_source("storage") == ParameterSource.COMMANDLINE:
        raise click.UsageError(f"--storage {storage}: applies to --to rosbag2 only (a rosbag1 bag is one .bag "
                               f"file in bag format 2.0, with no storage plugin); leave it out")
    res = export_rosbag(dataset_dir, out_path, kind=kind, storage=storage, truth=truth)
    if as_json:
        echo_json(res.to_dict())
        return
    total = sum(res.counts.values())
    click.echo(f"wrote {total} messages to {res.path} ({res.kind}, {res.storage}): "
               + ", ".join(f"{topic} {n}" for topic, n in res.counts.items()))
