"""``vo-testbed validate``: check error predictions against rendered images, and the IMU model."""
from __future__ import annotations

import click

from sim.app.cli.options import echo_json, json_option, set_option


def _floats(text: str, option: str) -> tuple:
    try:
        values = tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise click.BadParameter(f"expected comma-separated numbers like '0.12,0.27', got {text!r}",
                                 param_hint=option) from None
    if not values:
        raise click.BadParameter(f"expected at least one number, got {text!r}", param_hint=option)
    return values


@click.group("validate")
def validate():
    """Validate error-propagation predictions on rendered images."""


@validate.command("range")
@click.option("--rig", "rig_name", default="stereo27", show_default=True, help="Rig preset (baseline is overridden).")
@click.option("--baselines", default="0.063,0.12,0.27,0.5", show_default=True, help="Baselines (m).")
@click.option("--ranges", default="2,3,5,7,10,15,20,25,30", show_default=True, help="Board ranges (m).")
@click.option("--matchers", default="klt,sgbm", show_default=True, help="Comma list of klt, sgbm.")
@click.option("--image-noise", type=click.FloatRange(min=0), default=1.0, show_default=True, help="Gaussian noise std (grey levels).")
@click.option("--phases", type=click.IntRange(min=1), default=16, show_default=True, help="Sub-pixel disparity phases per range.")
@click.option("--tolerance", type=click.FloatRange(min=0, min_open=True), default=0.2, show_default=True, help="Allowed |measured/predicted - 1|.")
@click.option("--min-samples", type=click.IntRange(min=1), default=30, show_default=True, help="Bins with fewer samples are not judged.")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default=None,
              help="Write range_validation.json and range_validation.png here.")
@click.option("--strict", is_flag=True, help="Exit with code 1 if any judged bin is outside the tolerance.")
@json_option
def range_cmd(rig_name, baselines, ranges, matchers, image_noise, phases, tolerance, min_samples, seed,
              out_dir, strict, as_json):
    """Measured vs predicted (seed 001 eq. 7) stereo range error per baseline, matcher and range."""
    from sim.app.validation.range_check import measure_range_errors
    from vo.pipeline import prepare_out_dir
    if out_dir:
        prepare_out_dir(out_dir)             # an unwritable place fails now, not after the measurement
    res = measure_range_errors(baselines=_floats(baselines, "--baselines"), ranges=_floats(ranges, "--ranges"),
                               matchers=tuple(m.strip() for m in matchers.split(",") if m.strip()),
                               image_noise=image_noise, seed=seed, rig=rig_name, min_samples=min_samples,
                               tolerance=tolerance, phases=phases)
    paths = res.write(out_dir) if out_dir else {}
    if as_json:
        echo_json(dict(res.to_dict(), files=paths))
    else:
        click.echo(res.table())
        for kind, path in paths.items():
            click.echo(f"wrote {kind}: {path}")
    if strict and not res.passed:
        raise SystemExit(1)


@validate.command("imu")
@click.option("--scene", default="campus", show_default=True)
@click.option("--rig", "rig_name", default="cart27", show_default=True)
@click.option("--duration", type=click.FloatRange(min=0, min_open=True), default=60.0, show_default=True)
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--motion", "motion_file", type=click.Path(dir_okay=False), default=None,
              help="Replay this trajectory (as generate --motion) instead of the scene's route.")
@click.option("--motion-frame", type=click.Choice(["body", "imu", "cam0"]), default="body", show_default=True)
@set_option
@json_option
def imu_cmd(scene, rig_name, duration, seed, motion_file, motion_frame, overrides, as_json):
    """Dead-reckon the ideal IMU from the true initial state and print the error against the truth."""
    from sim.app.validation.imu_check import dead_reckoning
    sets = (f"replay.file={motion_file}", f"replay.frame={motion_frame}") if motion_file else ()
    res = dead_reckoning(scene, rig_name, duration, seed, sets + tuple(overrides))
    echo_json(res.to_dict()) if as_json else click.echo(res.text())


@validate.command("allan")
@click.option("--imu", "imu_name", default="euroc-adis16448", show_default=True)
@click.option("--hours", type=click.FloatRange(min=0, min_open=True), default=2.0, show_default=True)
@click.option("--seed", type=int, default=0, show_default=True)
@json_option
def allan_cmd(imu_name, hours, seed, as_json):
    """Allan deviation of a long static noisy IMU against the model's densities."""
    from sim.app.validation.imu_check import allan_check
    res = allan_check(imu_name, hours, seed)
    echo_json(res.to_dict()) if as_json else click.echo(res.text())


@validate.command("traffic")
@click.option("--scenario", default="urban-dynamic", show_default=True, help="Scenario rendered (unless --data).")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--data", "data_dir", type=click.Path(file_okay=False), default=None,
              help="Measure a generated EuRoC folder (written with --segmentation) instead of rendering.")
@click.option("--blocks", type=click.IntRange(min=1), default=8, show_default=True,
              help="Blocks of consecutive frames, spread evenly over the route.")
@click.option("--block-frames", type=click.IntRange(min=2), default=12, show_default=True, help="Frames per block.")
@click.option("--figure", type=click.Path(dir_okay=False), default=None,
              help="Write a PNG of one frame with its tracked features coloured static / dynamic.")
@click.option("--strict", is_flag=True, help="Exit with code 1 unless both targets are met.")
@click.option("--no-progress", is_flag=True)
@set_option
@json_option
def traffic_cmd(scenario, seed, data_dir, blocks, block_frames, figure, strict, no_progress, overrides, as_json):
    """Shi-Tomasi corner density of the traffic against the background, and the fraction of tracked
    features on moving actors (targets: ratio <= 1.5, fraction >= 15 %)."""
    from sim.app.validation.traffic_texture import check_traffic, dataset_frames, plot_features, scenario_frames
    if data_dir:
        frames, actors, moving = dataset_frames(data_dir)
        source = str(data_dir)
    else:
        from sim.scenarios import get_scenario
        config = get_scenario(scenario, overrides, seed=seed)
        frames, actors, moving = scenario_frames(config, blocks, block_frames, progress=not (no_progress or as_json))
        source = f"{scenario} seed {seed}"
    res = check_traffic(frames, actors, moving, source)
    out = res.to_dict()
    if figure:
        k, n_s, n_d = plot_features(frames, moving, figure, f"{source}, ")
        out["figure"] = {"path": figure, "frame": k, "static": n_s, "dynamic": n_d}
    if as_json:
        echo_json(out)
    else:
        click.echo(res.table())
        if figure:
            click.echo(f"wrote {figure}: frame {out['figure']['frame']}, {n_s} static / {n_d} dynamic features")
    if strict and not res.passed:
        raise SystemExit(1)


@validate.command("places")
@click.option("--scenario", default="campus", show_default=True, help="Scenario whose route is sampled.")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--spacing", type=click.FloatRange(min=0.5), default=2.0, show_default=True,
              help="Distance between sampled places along the route (m).")
@click.option("--figure", type=click.Path(dir_okay=False), default=None,
              help="Write a PNG: similarity histogram and the most similar distinct places.")
@click.option("--verify", type=click.Choice(["pnp", "fundamental"]), default="pnp", show_default=True,
              help="Geometric check of the matches: a rigid motion of A's 3-D points (pnp) or epipolar (fundamental).")
@click.option("--strict", is_flag=True, help="Exit with code 1 if a distinct pair is as similar as a revisit.")
@click.option("--no-progress", is_flag=True)
@set_option
@json_option
def places_cmd(scenario, seed, spacing, figure, verify, strict, no_progress, overrides, as_json):
    """Look-alike places: ORB + RANSAC similarity of distinct places (no co-visible surface) against revisits."""
    from sim.app.validation.place_recognition import PlaceConfig, check_places, plot_places, render_views
    from sim.scenarios import get_scenario
    config = get_scenario(scenario, overrides, seed=seed)
    place = PlaceConfig(spacing_m=spacing, verify=verify)
    progress = not (no_progress or as_json)
    places, revisits = render_views(config, place, progress=progress)
    res, matcher = check_places(places, revisits, f"{scenario} seed {seed}", place, progress=progress)
    out = res.to_dict()
    if figure:
        plot_places(res, places, revisits, matcher, figure)
        out["figure"] = figure
    if as_json:
        echo_json(out)
    else:
        click.echo(res.table())
        if figure:
            click.echo(f"wrote {figure}")
    if strict and not res.passed:
        raise SystemExit(1)
