"""``vo-testbed generate``: write a synthetic dataset.

The configuration is assembled in one order: a start (``--config FILE``, ``--scenario NAME`` or the
defaults), then every flag given on the command line (flags win), then the ``--set`` items in order.
The resolved whole is what ``metadata.yaml`` records.
"""
from __future__ import annotations

import click
from click.core import ParameterSource

from sim.app.cli.options import echo_json, json_option, set_option

# command-line parameter -> GenerateConfig field path (applied only when given on the command line)
FLAG_FIELDS = {"scene": "scene.name", "rig": "rig", "duration": "duration_s", "seed": "seed", "fmt": "format",
               "depth": "depth", "depth_format": "depth_format", "segmentation": "segmentation", "ideal": "ideal",
               "images": "images", "rgb": "rgb", "vehicle": "vehicle",
               "motion_file": "replay.file", "motion_frame": "replay.frame",
               "motion_times": "replay.times"}


@click.command("generate")
@click.option("--scene", default="campus", show_default=True, help="Scene name (see `vo-testbed list`).")
@click.option("--rig", default="cart27", show_default=True,
              help="Rig preset, rig .yaml, or a Kalibr camchain-imucam.yaml (see `vo-testbed list`).")
@click.option("--imu", "imu_yaml", type=click.Path(dir_okay=False), default=None,
              help="Kalibr imu.yaml for a --rig camchain-imucam.yaml (noise densities, random walks, rate, T_i_b).")
@click.option("--scenario", default=None, help="Start from a named scenario (flags and --set then change it).")
@click.option("--vehicle", default="cart", show_default=True, help="Vehicle: cart, car, rover, handheld or drone.")
@click.option("--motion", "motion_file", type=click.Path(dir_okay=False), default=None,
              help="Replay this trajectory (TUM, EuRoC ground-truth CSV, or KITTI poses with times.txt beside "
                   "them) through a smooth SE(3) spline instead of driving the scene's route (sim.replay).")
@click.option("--motion-frame", "motion_frame", type=click.Choice(["body", "imu", "cam0"]), default="body",
              show_default=True, help="Whose poses the --motion file holds.")
@click.option("--motion-times", "motion_times", type=click.Path(dir_okay=False), default=None,
              help="times.txt (seconds, one per pose) of --motion KITTI poses, when it is not beside them.")
@click.option("--config", "config_file", type=click.Path(dir_okay=False), default=None,
              help="Start from a YAML file whose keys are GenerateConfig fields (scene, rig, duration_s, seed, "
                   "format, depth, depth_format, segmentation, ideal, images, vehicle, rgb, motion, render, noise; "
                   "a dataset's metadata.yaml 'config' block is one); flags given and --set items win over it.")
@click.option("--duration", type=float, default=None, help="Seconds to simulate; default: the whole route.")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False), help="Output folder.")
@click.option("--format", "fmt", type=click.Choice(["euroc", "kitti", "both", "rosbag1", "rosbag2"]), default="euroc",
              show_default=True, help="both: euroc/ and kitti/ sub-folders; rosbag1|rosbag2: EuRoC folder plus a bag "
                                      "(dataset.bag, or rosbag2/ with MCAP storage) converted from it.")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--depth/--no-depth", default=False,
              help="Also write per-frame depth along the optical axis (see --depth-format).")
@click.option("--depth-format", type=click.Choice(["npy", "png16-mm", "tum", "png16"]), default="npy", show_default=True,
              help="npy: exact float32 m, inf = sky; png16-mm: uint16 millimetres, 0 = sky (26x smaller); tum: uint16 "
                   "at TUM RGB-D's 5000 per metre (0.2 mm steps, up to 13.1 m), 0 = sky; png16: alias of png16-mm.")
@click.option("--segmentation/--no-segmentation", default=False,
              help="Also write per-frame segmentation (object id, dynamic flag).")
@click.option("--ideal/--no-ideal", default=False, help="Turn every noise source off (IMU, image noise).")
@click.option("--images/--no-images", default=True, help="--no-images: write IMU and ground truth only (seconds).")
@click.option("--rgb/--no-rgb", default=False, help="Write RGB images (default: 8-bit grey, as EuRoC and KITTI).")
@click.option("--overwrite", is_flag=True, help="Replace a complete dataset already in --out.")
@click.option("--no-progress", is_flag=True)
@click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True,
              help="Render frame ranges in N processes, each with its own GL context (same bytes as 1); "
                   "not with camera.auto_exposure.")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Render the frame ranges on the Dask cluster at ADDRESS (needs the sweep extra).")
@click.option("--egl-devices", default=None, metavar="LIST",
              help="With --workers: EGL devices (MUJOCO_EGL_DEVICE_ID) given out to the worker processes in "
                   "turn, e.g. 0,1,2,3.")
@click.option("--threads", type=click.IntRange(min=0), default=None,
              help="Threads that add noise, encode and write frames (default: one per CPU; 0: serial).")
@set_option
@json_option
@click.pass_context
def generate(ctx, scenario, config_file, out_dir, overwrite, no_progress, workers, scheduler, egl_devices, threads,
             overrides, as_json, **flags):
    """Generate a dataset (EuRoC, KITTI or both) with exact ground truth, GCPs and a top-down PNG."""
    from sim.app.rosbag_export import export_rosbag
    from sim.generate import generate as run

    from sim.scenarios import traverse_scenarios
    if scenario in traverse_scenarios():
        return _traverse(ctx, scenario, config_file, out_dir, overwrite, no_progress, overrides, as_json, flags)
    cfg = build_config(ctx, scenario, config_file, flags, overrides)
    devices = tuple(d.strip() for d in egl_devices.split(",") if d.strip()) if egl_devices else ()
    res = run(cfg, out_dir, progress=not no_progress and not as_json, overwrite=overwrite, threads=threads,
              workers=workers, scheduler=scheduler, egl_devices=devices, bag_export=export_rosbag)
    for note in res.notes:
        click.echo(f"warning: {note}", err=True)
    if res.replay_departure and not as_json:
        from sim.replay import Departure
        click.echo(f"replay {cfg.replay.file}: {Departure(**res.replay_departure).text()}")
    if as_json:
        echo_json(res.to_dict())
    else:
        from sim.writers.fanout import output_paths
        where = " and ".join(str(p) for p in output_paths(res.out_dir, cfg.format))
        click.echo(f"wrote {res.n_frames} stereo frames, {res.n_imu} IMU samples, {res.duration_s:.1f} s, "
                   f"{res.path_length_m:.1f} m to {where} ({', '.join(res.formats)}); top-down: {res.topdown_png}")


def build_config(ctx, scenario, config_file, flags: dict, overrides):
    """Start (file, scenario or defaults) -> flags given on the command line -> ``--set`` items. The
    plain flags are applied together, so a combination valid as a whole (``--format kitti --images``
    over a file with ``images: false``) is accepted."""
    import dataclasses
    from sim.generate_config import GenerateConfig, load_generate_config
    from sim.scenarios import get_scenario

    if config_file and scenario:
        raise click.UsageError("give --config or --scenario, not both")
    cfg = load_generate_config(config_file) if config_file else \
        get_scenario(scenario) if scenario else GenerateConfig()
    given = [n for n in FLAG_FIELDS
             if ctx.get_parameter_source(n) in (ParameterSource.COMMANDLINE, ParameterSource.ENVIRONMENT)]
    if flags.get("imu_yaml"):                                    # Kalibr camchain + imu.yaml
        if "rig" not in given:
            raise click.UsageError("--imu imu.yaml goes with --rig camchain-imucam.yaml (a Kalibr camchain)")
        flags = dict(flags, rig={"kalibr": flags["rig"], "imu": flags["imu_yaml"]})
    plain = [n for n in given if "." not in FLAG_FIELDS[n] and n != "rig"]
    for name in (n for n in given if n not in plain):            # --scene, --rig
        cfg = _labelled([name], cfg.with_value, FLAG_FIELDS[name], flags[name])
    cfg = _labelled(plain, dataclasses.replace, cfg, **{FLAG_FIELDS[n]: flags[n] for n in plain})
    return cfg.with_overrides(overrides, source="--set")


def _labelled(names: list, fn, *args, **kwargs):
    """``fn(*args, **kwargs)``; an error is prefixed with the flag it names (or the only flag given)."""
    from rigs.errors import TestbedError
    try:
        return fn(*args, **kwargs)
    except TestbedError as exc:
        msg = str(exc)
        hit = [n for n in names if msg.startswith(FLAG_FIELDS[n] + ":")] or (names if len(names) == 1 else [])
        if not hit:
            raise
        flag = "format" if hit[0] == "fmt" else hit[0].replace("_", "-")
        if f"--{flag}" in msg or f"--no-{flag}" in msg:          # the message names the flag already
            raise
        raise type(exc)(f"--{flag}: {msg}") from None


def _traverse(ctx, scenario, config_file, out_dir, overwrite, no_progress, overrides, as_json, flags):
    """A stop-and-go traverse scenario: ``--set traverse.<field>=v`` items go to its TraverseConfig."""
    from rigs.typed_config import replace_path, split_item
    from sim.generate_traverse import generate_traverse
    from sim.errors import SimError
    from sim.scenarios import traverse_scenarios
    tcfg = traverse_scenarios()[scenario]
    rest = []
    for item in overrides:
        key, value = split_item(item, "--set", SimError)
        if key.startswith("traverse."):
            tcfg = replace_path(tcfg, key.partition(".")[2], value, SimError)
        else:
            rest.append(item)
    cfg = build_config(ctx, scenario, config_file, flags, tuple(rest))
    res = generate_traverse(cfg, tcfg, out_dir, progress=not no_progress and not as_json, overwrite=overwrite)
    if as_json:
        echo_json(res)
    else:
        click.echo(f"wrote a traverse of {res['n_sites']} sites ({res['n_pairs']} stereo pairs), "
                   f"{res['path_length_m']:.1f} m, {res['duration_s']:.0f} s to {res['out_dir']}; map: {res['map_png']}")
