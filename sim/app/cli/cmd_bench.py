"""``vo-testbed bench``: speed benchmarks that print figures."""
from __future__ import annotations

import click

from sim.app.cli.options import echo_json, json_option, opt_option, parse_opts


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
@json_option
def vo_cmd(scenarios, estimators, all_cores, max_frames, no_progress, estimator_opts, as_json):
    """Drift ratio, GCP RMSD, ATE and ms per frame per stage of each estimator on each scenario."""
    from sim.app.bench_vo import bench_estimators, format_rows
    rows = bench_estimators(tuple(scenarios) or ("campus", "indoor"),
                            tuple(estimators) or ("rop", "klt-pnp", "orb-pnp"), one_core=not all_cores,
                            progress=not (no_progress or as_json), max_frames=max_frames,
                            options=parse_opts(estimator_opts))
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
    from vo.crosssite.traverse import localize_dataset, site_table, timing_table
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
