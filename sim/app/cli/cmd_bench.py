"""``vo-testbed bench``: speed benchmarks that print figures."""
from __future__ import annotations

import click

from sim.app.cli.options import echo_json, json_option, opt_option, parse_opts, set_option


@click.group("bench")
def bench():
    """Benchmarks (rendering speed, estimator speed)."""


@bench.command("render")
@click.option("--scene", "scenes", multiple=True, help="Scene(s) to time; default: all.")
@click.option("--pairs", type=click.IntRange(min=1), default=40, show_default=True, help="Stereo pairs rendered per scene.")
@click.option("--shadows", is_flag=True, help="Also time with shadows on.")
@json_option
def render(scenes, pairs, shadows, as_json):
    """Stereo pairs per second at 752x480 for each scene (stereo27 rig)."""
    from scenes.registry import scene_names
    from sim.app.bench_render import bench_render
    names = tuple(scenes) or tuple(scene_names())
    results = list(bench_render(names, n_pairs=pairs, shadows=False))
    if shadows:
        results += list(bench_render(names, n_pairs=pairs, shadows=True))
    if as_json:
        echo_json([r.__dict__ if not hasattr(r, "to_dict") else r.to_dict() for r in results])
        return
    click.echo(f"{'scene':<10} {'size':>9} {'shadows':>7} {'pairs/s':>8} {'ms/pair':>8} {'CPU ms/pair':>11} "
               f"{'build s':>8} {'build CPU s':>11} {'texture MB':>10}")
    for r in results:
        click.echo(f"{r.scene:<10} {r.width}x{r.height:<5} {str(r.shadows):>7} {r.pairs_per_s:8.1f} {r.ms_per_pair:8.1f} "
                   f"{r.cpu_ms_per_pair:11.1f} {r.build_s:8.1f} {r.build_cpu_s:11.1f} {r.texture_mb:10.1f}")


@bench.command("vo")
@click.option("--scenario", "scenarios", multiple=True, help="Scenario(s); default: campus and indoor.")
@click.option("--estimator", "estimators", multiple=True, help="Estimator(s); default: rop, klt-pnp, orb-pnp.")
@click.option("--all-cores", is_flag=True, help="Let OpenCV use every core (default: one thread).")
@click.option("--max-frames", type=click.IntRange(min=1), default=None)
@click.option("--no-progress", is_flag=True)
@opt_option
@set_option
@json_option
def vo_cmd(scenarios, estimators, all_cores, max_frames, no_progress, estimator_opts, overrides, as_json):
    """Drift ratio, GCP RMSD, ATE and ms per frame per stage of each estimator on each scenario."""
    from sim.app.bench_vo import bench_estimators, format_rows
    rows = bench_estimators(tuple(scenarios) or ("campus", "indoor"),
                            tuple(estimators) or ("rop", "klt-pnp", "orb-pnp"), one_core=not all_cores,
                            progress=not (no_progress or as_json), max_frames=max_frames,
                            options=parse_opts(estimator_opts), overrides=overrides)
    echo_json([r.to_dict() for r in rows]) if as_json else click.echo(format_rows(rows))


@bench.command("real")
@click.option("--dataset", "datasets", multiple=True, required=True, type=click.Path(),
              help="A recording (repeatable): a KITTI odometry sequences/NN folder (poses/NN.txt two levels up), "
                   "a EuRoC folder holding mav0/, or one of ours.")
@click.option("--estimator", "estimators", multiple=True, help="Estimator(s); default: rop, klt-pnp.")
@click.option("--out", "out_dir", type=click.Path(), default="bench-real", show_default=True,
              help="Folder for one <recording>_trajectory.png per recording.")
@click.option("--all-cores", is_flag=True, help="Let OpenCV use every core (default: one thread).")
@click.option("--max-frames", type=click.IntRange(min=2), default=None, help="Only the first N frames of each.")
@click.option("--noise-draws", type=click.IntRange(min=0), default=0, show_default=True,
              help="Also run each estimator on N copies of each recording with seeded image noise added, and give "
                   "the drift of every draw: how far the noise alone moves a figure.")
@click.option("--noise-sigma", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Grey levels of the noise added per draw (default 0.5).")
@click.option("--stride", type=click.IntRange(min=1), default=1, show_default=True,
              help="Read every Nth frame of each recording: N times the motion between frames (a faster drive "
                   "or a slower camera).")
@click.option("--no-progress", is_flag=True)
@opt_option
@json_option
def real_cmd(datasets, estimators, out_dir, all_cores, max_frames, noise_draws, noise_sigma, stride, no_progress,
             estimator_opts, as_json):
    """Drift, ATE, RPE, KITTI segment errors, ms per frame and frames by status of each estimator on each
    recorded dataset (real KITTI odometry / EuRoC), with a trajectory plot per recording."""
    from sim.app.bench_real import DEFAULT_ESTIMATORS, bench_real, format_rows
    rows = bench_real(datasets, tuple(estimators) or DEFAULT_ESTIMATORS, out_dir=out_dir, one_core=not all_cores,
                      progress=not (no_progress or as_json), max_frames=max_frames,
                      options=parse_opts(estimator_opts), noise_draws=noise_draws, noise_sigma=noise_sigma,
                      stride=stride)
    echo_json([r.to_dict() for r in rows]) if as_json else click.echo(format_rows(rows))


@bench.command("localize")
@click.option("--dataset", required=True, type=click.Path(), help="Traverse dataset folder.")
@click.option("--mode", type=click.Choice(["ff", "fb"]), default="ff", show_default=True)
@click.option("--max-sites", type=click.IntRange(min=0), default=3, show_default=True,
              help="Only the first N sites (0: all); N-1 site pairs are timed.")
@click.option("--pair", "pairs", multiple=True, type=click.IntRange(min=1), metavar="K",
              help="Time only site pair K-1 -> K (repeatable), the previous site at its --poses pose (else true).")
@click.option("--poses", type=click.Path(exists=True, dir_okay=False),
              help="With --pair: site_poses_tum.txt of a `vo-testbed localize` run on this dataset.")
@click.option("--set", "items", multiple=True, metavar="FIELD=VALUE", help="A CrossSiteConfig field (repeatable).")
@json_option
def localize_cmd(dataset, mode, max_sites, pairs, poses, items, as_json):
    """Stage timings (s) of the cross-site localizer per site pair (target: <= 120 s per pair)."""
    from sim.app.cli.cmd_localize import crosssite_config
    from vo.crosssite.traverse_eval import localize_dataset, site_table, timing_table
    cfg = crosssite_config(mode, items)
    if pairs:
        from sim.app.bench_localize import localize_pairs
        rows = localize_pairs(dataset, cfg, pairs, poses)
    else:
        if poses:
            raise click.UsageError("--poses needs --pair")
        rows = [dict(r, true_inliers=r["truth"].get("n_true_inliers", 0))
                for r in site_table(localize_dataset(dataset, cfg, max_sites, progress=not as_json))[1:]]
    keys = ("site", "status", "tie_points", "true_inliers", "ba_err_m", "time_s", "timings_s")
    echo_json([{k: r[k] for k in keys if k in r} for r in rows]) if as_json else click.echo(timing_table(rows))


@bench.command("generate")
@click.option("--scenario", default="campus-short", show_default=True, help="Scenario to generate.")
@click.option("--frames", type=click.IntRange(min=0), default=100, show_default=True,
              help="Its first N frames (0: the whole route).")
@click.option("--threads", type=click.IntRange(min=0), default=None,
              help="Worker threads of the frame pipeline (default: one per CPU; 0: the serial loop).")
@click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True,
              help="Render processes of the end-to-end run (generate --workers).")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Render on this Dask cluster (generate --scheduler).")
@click.option("--repeat", type=click.IntRange(min=1), default=1, show_default=True,
              help="Alternate render-only and end-to-end runs N times; the best of each is kept.")
@click.option("--png-levels", is_flag=True, help="Instead: PNG size and encoding time at zlib levels 0-9.")
@click.option("--noise", is_flag=True, help="Instead: CPU ms per 752x480 pair of the image noise draws.")
@set_option
@json_option
def generate_cmd(scenario, frames, threads, workers, scheduler, repeat, png_levels, noise, overrides, as_json):
    """Render-only and end-to-end pairs/s, their ratio, ms per pair and stage, peak memory."""
    from sim.app.bench_generate import bench_generate, format_bench, format_levels
    from sim.app.bench_generate import png_levels as levels
    if noise:
        from sim.app.bench_generate import noise_cost
        ms = noise_cost()
        echo_json(ms) if as_json else click.echo("\n".join(f"{k:<28} {v:6.2f} CPU ms/pair" for k, v in ms.items()))
        return
    if png_levels:
        rows = levels(scenario, frames=min(frames or 10, 10), overrides=overrides)
        echo_json(rows) if as_json else click.echo(format_levels(rows))
        return
    say = None if as_json else (lambda m: click.echo(m, err=True))
    b = bench_generate(scenario, frames, threads, repeat, overrides, progress=say, workers=workers,
                       scheduler=scheduler)
    echo_json(b.to_dict()) if as_json else click.echo(format_bench(b))
