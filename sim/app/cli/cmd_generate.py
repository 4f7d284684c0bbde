"""``vo-testbed generate``: write a synthetic dataset."""
from __future__ import annotations

import click

from sim.app.cli.options import echo_json, json_option, set_option


@click.command("generate")
@click.option("--scene", default="campus", show_default=True, help="Scene name (see `vo-testbed list`).")
@click.option("--rig", default="cart27", show_default=True, help="Rig preset (see `vo-testbed list`).")
@click.option("--scenario", default=None, help="Start from a named scenario instead of --scene/--rig/--duration.")
@click.option("--config", "config_file", type=click.Path(dir_okay=False), default=None,
              help="YAML file whose keys are GenerateConfig fields (scene, rig, duration_s, seed, format, depth, "
                   "segmentation, ideal, images, rgb, image_noise, overrides); command-line flags are ignored.")
@click.option("--duration", type=float, default=None, help="Seconds to simulate; default: the whole route.")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False), help="Output folder.")
@click.option("--format", "fmt", type=click.Choice(["euroc", "kitti", "both"]), default="euroc", show_default=True)
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--depth", is_flag=True, help="Also write per-frame depth (float32 m along the optical axis, .npy).")
@click.option("--segmentation", is_flag=True, help="Also write per-frame segmentation (object id, dynamic flag).")
@click.option("--ideal", is_flag=True, help="Turn every noise source off (IMU, image noise).")
@click.option("--no-images", is_flag=True, help="Write IMU and ground truth only (seconds).")
@click.option("--rgb", is_flag=True, help="Write RGB images (default: 8-bit grey, as EuRoC and KITTI odometry).")
@click.option("--overwrite", is_flag=True, help="Replace a complete dataset already in --out.")
@click.option("--no-progress", is_flag=True)
@set_option
@json_option
def generate(scene, rig, scenario, config_file, duration, out_dir, fmt, seed, depth, segmentation, ideal, no_images, rgb,
             overwrite, no_progress, overrides, as_json):
    """Generate a dataset (EuRoC, KITTI or both) with exact ground truth, GCPs and a top-down PNG."""
    from sim.config import GenerateConfig
    from sim.generate import generate as run
    from sim.scenarios import get_scenario

    if config_file:
        from sim.config import load_generate_config
        cfg = load_generate_config(config_file)
    elif scenario:
        base = get_scenario(scenario, overrides=overrides, seed=seed)
        cfg = GenerateConfig(**{**base.to_dict(), "format": fmt, "depth": depth, "segmentation": segmentation,
                                "ideal": ideal, "images": not no_images, "rgb": rgb,
                                **({"duration_s": duration} if duration else {})})
    else:
        cfg = GenerateConfig(scene=scene, rig=rig, duration_s=duration, seed=seed, format=fmt, depth=depth,
                             segmentation=segmentation, ideal=ideal, images=not no_images, rgb=rgb,
                             overrides=overrides)
    res = run(cfg, out_dir, progress=not no_progress and not as_json, overwrite=overwrite)
    if as_json:
        echo_json(res.to_dict())
    else:
        click.echo(f"wrote {res.n_frames} stereo frames, {res.n_imu} IMU samples, {res.duration_s:.1f} s, "
                   f"{res.path_length_m:.1f} m to {res.out_dir} ({', '.join(res.formats)}); top-down: {res.topdown_png}")
