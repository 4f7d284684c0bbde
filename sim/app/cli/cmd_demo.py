"""``vo-testbed demo``: the main job on a built-in scenario."""
from __future__ import annotations

import click

from sim.app.cli.options import echo_json, json_option, opt_option, parse_opts


@click.command("demo")
@click.option("--scenario", default="campus", show_default=True, help="Named scenario (see `vo-testbed list`).")
@click.option("--estimators", default="rop,klt-pnp,orb-pnp", show_default=True,
              help="Comma-separated estimators (names, 'package.module:Class' or 'cmd:...'); checked before "
                   "anything is rendered.")
@click.option("--out", "out_dir", default="out/demo", show_default=True, type=click.Path(file_okay=False))
@click.option("--max-frames", type=click.IntRange(min=1), default=None, help="Only the first N frames (quick look).")
@click.option("--no-progress", is_flag=True)
@opt_option
@json_option
def demo(scenario, estimators, out_dir, max_frames, no_progress, estimator_opts, as_json):
    """Generate SCENARIO (cached), run the estimators, print seed 000's Table 4 for each, write plots.
    urban-static / urban-dynamic: seed 002's Tables 2/3 and Figs. 12-15 for the VINS configurations, from the
    monocular start (--opt init=truth: from the true states; --opt is for these two scenarios only).

    Exit code 2 when an estimator name is unknown (before any work) or an estimator failed on the data."""
    from sim.app.demo import run_demo
    from sim.errors import SimError
    res = run_demo(scenario, tuple(e.strip() for e in estimators.split(",") if e.strip()), out_dir,
                   progress=not (no_progress or as_json), max_frames=max_frames, options=parse_opts(estimator_opts))
    echo_json(res.to_dict()) if as_json else click.echo(res.text())
    if res.errors:
        raise SimError(f"{len(res.errors)} estimator(s) failed: {', '.join(res.errors)}")
